"""A run directory and its life: create, evaluate generation by generation, checkpoint, resume, finish.

Layout of ``runs/<UTC time>-<name>-<6 hex>/``:

``config.yaml``       the resolved config, defaults filled in, as run
``meta.json``         status (running/finished/interrupted/failed), seed, times, versions, git commit,
                      host, CPU count, backend, evaluation counts, stop reason
``history.csv``       one row per evaluation: eval, stage, generation, index, every parameter,
                      fitness, status, error, seconds, metrics (the record of truth)
``best.yaml``         best parameters, fitness, metrics, where it was found (updated every generation)
``checkpoint.pkl``    optimiser state with its RNG, written atomically after each generation
``report.md``, ``figures/``  written when the run finishes

The loop only asks, evaluates and tells; the optimiser never sees the evaluator. History rows of a
generation are flushed to disk before the checkpoint that covers them is renamed into place, and a
resumed run first cuts the history back to what its checkpoint covers, so a run killed at any
moment resumes to exactly the result of an uninterrupted run.
"""

from __future__ import annotations

import csv
import datetime as _dt
import io
import json
import math
import os
import pickle
import platform
import secrets
import signal
import socket
import subprocess
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from tuner.config import ConfigError, RunConfig, config_from_dict
from tuner.evaluate import EvalRecord, Evaluator
from tuner.optimizers import get_optimizer
from tuner.space import Space

__all__ = ["RunResult", "run", "resume", "atomic_write", "read_meta", "load_best", "RunError"]

CHECKPOINT = "checkpoint.pkl"
FIXED_COLUMNS = ["eval", "stage", "generation", "index"]
RESULT_COLUMNS = ["fitness", "status", "error", "seconds"]


class RunError(RuntimeError):
    """A run directory that cannot be used as asked (missing, finished, corrupt)."""


@dataclass(frozen=True)
class RunResult:
    """What a finished (or interrupted) run produced."""

    run_dir: Path
    status: str
    best_params: dict[str, Any]
    best_fitness: float
    best_metrics: dict[str, Any]
    n_evals: int
    generations: int
    stop_reason: str
    extra: dict[str, Any] = field(default_factory=dict)


# --- small file helpers ------------------------------------------------------------------------
def atomic_write(path: Path, data: bytes | str) -> None:
    """Write to a temporary file, fsync, rename: readers see the old or the new file, never half."""
    path = Path(path)
    tmp = path.with_name(f".{path.name}.tmp{os.getpid()}")
    mode = "wb" if isinstance(data, bytes) else "w"
    with open(tmp, mode) as fh:
        fh.write(data)
        fh.flush()
        os.fsync(fh.fileno())
    os.replace(tmp, path)
    try:
        dfd = os.open(path.parent, os.O_RDONLY)
        try:
            os.fsync(dfd)
        finally:
            os.close(dfd)
    except OSError:  # pragma: no cover - some filesystems refuse directory fsync
        pass


def _plain(v: Any) -> Any:
    if isinstance(v, dict):
        return {str(k): _plain(x) for k, x in v.items()}
    if isinstance(v, (list, tuple)):
        return [_plain(x) for x in v]
    if isinstance(v, np.generic):
        return v.item()
    if isinstance(v, np.ndarray):
        return v.tolist()
    if isinstance(v, Path):
        return str(v)
    return v


def _dump_yaml(d: Any) -> str:
    return yaml.safe_dump(_plain(d), sort_keys=False, default_flow_style=False, width=100)


def read_meta(run_dir: Path) -> dict[str, Any]:
    p = Path(run_dir) / "meta.json"
    if not p.exists():
        raise RunError(f"{run_dir}: not a run directory (no meta.json)")
    return json.loads(p.read_text())


def load_best(run_dir: str | Path) -> dict[str, Any]:
    """The best parameters of a run (from ``best.yaml``) as a plain dict."""
    p = Path(run_dir) / "best.yaml"
    if not p.exists():
        raise RunError(f"{run_dir}: no best.yaml (has the run evaluated anything yet?)")
    return dict(yaml.safe_load(p.read_text())["params"])


def _git_commit() -> str:
    try:
        root = Path(__file__).resolve().parents[1]
        out = subprocess.run(["git", "-C", str(root), "rev-parse", "HEAD"], capture_output=True, text=True,
                             timeout=5)
        return out.stdout.strip() if out.returncode == 0 else ""
    except (OSError, subprocess.SubprocessError):
        return ""


def _versions() -> dict[str, str]:
    out = {"python": platform.python_version()}
    for mod in ("numpy", "scipy", "numba", "joblib", "pandas", "cma", "yaml"):
        try:
            out[mod] = getattr(__import__(mod), "__version__", "")
        except ImportError:  # pragma: no cover
            out[mod] = ""
    from tuner import __version__

    out["tuner"] = __version__
    return out


def _now() -> str:
    return _dt.datetime.now(_dt.UTC).strftime("%Y-%m-%dT%H:%M:%SZ")


# --- history -----------------------------------------------------------------------------------
class History:
    """Append-only ``history.csv``; the header grows (file rewritten) if new metric names appear."""

    def __init__(self, path: Path, param_names: list[str], metric_names: list[str] | None = None):
        self.path = path
        self.param_names = list(param_names)
        self.metric_names = list(metric_names or [])
        if not path.exists():
            self._rewrite([])

    @property
    def columns(self) -> list[str]:
        return FIXED_COLUMNS + self.param_names + RESULT_COLUMNS + self.metric_names

    def _rewrite(self, rows: list[dict[str, Any]]) -> None:
        buf = io.StringIO()
        w = csv.DictWriter(buf, fieldnames=self.columns, extrasaction="ignore", lineterminator="\n")
        w.writeheader()
        for r in rows:
            w.writerow(r)
        atomic_write(self.path, buf.getvalue())

    def read_rows(self) -> list[dict[str, str]]:
        with open(self.path, newline="") as fh:
            return list(csv.DictReader(fh))

    def truncate(self, n_rows: int) -> None:
        """Keep the first ``n_rows`` evaluations (what the checkpoint covers)."""
        rows = self.read_rows()
        if len(rows) != n_rows:
            self._rewrite(rows[:n_rows])

    def append(self, rows: list[dict[str, Any]]) -> None:
        new = sorted({k for r in rows for k in r} - set(self.columns))
        if new:
            old = self.read_rows()
            self.metric_names += new
            self._rewrite(old)
        buf = io.StringIO()
        w = csv.DictWriter(buf, fieldnames=self.columns, extrasaction="ignore", lineterminator="\n")
        for r in rows:
            w.writerow(r)
        with open(self.path, "a", newline="") as fh:
            fh.write(buf.getvalue())
            fh.flush()
            os.fsync(fh.fileno())


def _fmt(v: Any) -> Any:
    if isinstance(v, float):
        return repr(v)
    if isinstance(v, np.floating):
        return repr(float(v))
    if isinstance(v, (list, tuple, dict)):
        return json.dumps(_plain(v))
    return v


# --- the run -----------------------------------------------------------------------------------
class _Interrupted(Exception):
    pass


class Run:
    """Drives one run directory. Use :func:`run` and :func:`resume`."""

    def __init__(self, cfg: RunConfig, run_dir: Path, objective: Any, space: Space,
                 progress: Callable[[str], None] | None):
        self.cfg = cfg
        self.dir = run_dir
        self.objective = objective
        self.base_space = space
        self.progress = progress
        self.meta: dict[str, Any] = {}

    # --- creation -----------------------------------------------------------------------------
    @classmethod
    def create(cls, cfg: RunConfig, objective: Any, space: Space, run_dir: Path | None,
               progress: Callable[[str], None] | None) -> Run:
        if run_dir is None:
            stamp = _dt.datetime.now(_dt.UTC).strftime("%Y%m%dT%H%M%SZ")
            out = Path(cfg.output)
            if not out.is_absolute():
                out = Path.cwd() / out
            run_dir = out / f"{stamp}-{cfg.name}-{secrets.token_hex(3)}"
        run_dir = Path(run_dir)
        if run_dir.exists() and any(run_dir.iterdir()):
            raise RunError(f"{run_dir}: exists and is not empty; use `tuner resume {run_dir}` or another directory")
        run_dir.mkdir(parents=True, exist_ok=True)
        resolved = dict(cfg.raw)
        resolved["parameters"] = space.to_dict()
        resolved["source"] = str(cfg.source)
        resolved["base_dir"] = str(cfg.base_dir)
        atomic_write(run_dir / "config.yaml", _dump_yaml(resolved))
        self = cls(cfg, run_dir, objective, space, progress)
        self.meta = {
            "status": "created",
            "name": cfg.name,
            "seed": cfg.seed,
            "created": _now(),
            "config_source": str(cfg.source),
            "versions": _versions(),
            "git_commit": _git_commit(),
            "host": socket.gethostname(),
            "cpu_count": os.cpu_count(),
            "backend": cfg.parallel.backend,
            "n_jobs": cfg.parallel.n_jobs,
            "optimizer": cfg.optimizer.method,
            "n_evals": 0,
            "n_failed": 0,
            "generations": 0,
            "stop_reason": "",
            "timing": {"wall_s": 0.0, "objective_s": 0.0, "sessions": 0},
        }
        self._write_meta()
        return self

    def _write_meta(self) -> None:
        atomic_write(self.dir / "meta.json", json.dumps(_plain(self.meta), indent=1))

    # --- optimiser of a stage -----------------------------------------------------------------
    def _stage_space(self, stage: int, best_params: dict[str, Any] | None) -> Space:
        if stage == 0 or best_params is None:
            return self.base_space
        space = self.base_space
        for _ in range(stage):
            space = space.narrowed(best_params, self.cfg.optimizer.refine.shrink)
        return space

    def _new_optimizer(self, stage: int, space: Space, x0: np.ndarray | None):
        o = self.cfg.optimizer
        rng = np.random.default_rng(np.random.SeedSequence([self.cfg.seed, stage]))
        kwargs = dict(o.options)
        if o.population is not None:
            kwargs["population"] = o.population
        kwargs["generations"] = o.generations
        if x0 is not None:
            kwargs["x0"] = x0
        if isinstance(kwargs.get("x0"), dict):
            kwargs["x0"] = space.encode(kwargs["x0"])
        return get_optimizer(o.method)(space.dim, rng, **kwargs)

    # --- main loop ----------------------------------------------------------------------------
    def execute(self, ck: dict[str, Any] | None = None) -> RunResult:
        stages = self.cfg.optimizer.refine.stages
        if ck is None:
            stage, space = 0, self.base_space
            optimizer = self._new_optimizer(0, space, None)
            best: dict[str, Any] = {"fitness": math.inf, "params": None, "metrics": {}, "generation": -1,
                                    "stage": 0, "eval": -1}
            n_evals, n_failed = 0, 0
            conv: list[dict[str, Any]] = []
            history = History(self.dir / "history.csv", self.base_space.names)
        else:
            stage = ck["stage"]
            space = Space.from_dict(ck["space"])
            optimizer = get_optimizer(self.cfg.optimizer.method).from_state(ck["optimizer"])
            best, n_evals, n_failed, conv = ck["best"], ck["n_evals"], ck["n_failed"], ck["convergence"]
            history = History(self.dir / "history.csv", self.base_space.names, ck["metric_names"])
            history.truncate(n_evals)

        self.meta.update(status="running", started=self.meta.get("started") or _now())
        self.meta["timing"]["sessions"] += 1
        self._write_meta()
        t_session = time.perf_counter()
        wall0 = self.meta["timing"]["wall_s"]
        interrupted = False

        def on_term(signum, frame):  # SIGTERM behaves like Ctrl-C
            raise _Interrupted()

        old_handler = None
        try:
            old_handler = signal.signal(signal.SIGTERM, on_term)
        except ValueError:  # not in the main thread
            pass
        evaluator = Evaluator(self.objective, self.cfg.parallel.backend, self.cfg.parallel.n_jobs,
                              self.cfg.parallel.address)
        self.meta["backend_detail"] = evaluator.describe()
        try:
            while True:
                while not optimizer.done:
                    t0 = time.perf_counter()
                    u = optimizer.ask()
                    params = [space.decode(row) for row in u]
                    records = evaluator(params)
                    f = np.array([r.evaluation.fitness for r in records])
                    optimizer.tell(u, f)
                    rows = []
                    for i, (p, r) in enumerate(zip(params, records)):
                        rows.append(self._row(n_evals + i, stage, optimizer.generation - 1, i, p, r))
                        ev = r.evaluation
                        if ev.status == "ok" and ev.fitness < best["fitness"]:
                            best = {"fitness": float(ev.fitness), "params": _plain(p), "metrics": _plain(ev.metrics),
                                    "generation": optimizer.generation - 1, "stage": stage, "eval": n_evals + i}
                        n_failed += ev.status != "ok"
                    n_evals += len(records)
                    history.append(rows)
                    ok = f[[r.evaluation.status == "ok" for r in records]]
                    conv.append({"stage": stage, "generation": optimizer.generation - 1, "n_evals": n_evals,
                                 "best": best["fitness"], "gen_best": float(ok.min()) if len(ok) else math.nan,
                                 "gen_median": float(np.median(ok)) if len(ok) else math.nan})
                    obj_s = sum(r.seconds for r in records)
                    self.meta["timing"]["objective_s"] += obj_s
                    self._checkpoint(stage, space, optimizer, best, n_evals, n_failed, conv, history)
                    self.meta.update(n_evals=n_evals, n_failed=n_failed, generations=len(conv))
                    self.meta["timing"]["wall_s"] = wall0 + time.perf_counter() - t_session
                    self._write_meta()
                    if best["params"] is not None:
                        self._write_best(best, space)
                    self._live_report()
                    self._progress(stage, stages, optimizer, best, len(records), time.perf_counter() - t0,
                                   n_failed)
                if stage + 1 >= stages or best["params"] is None:
                    break
                stage += 1
                space = self._stage_space(stage, best["params"])
                optimizer = self._new_optimizer(stage, space, space.encode(
                    {k: v for k, v in best["params"].items() if k in space.free_names}))
                if self.progress:
                    ranges = ", ".join(f"{p.name} [{p.low:.4g}, {p.high:.4g}]" for p in space.free)
                    self.progress(f"stage {stage + 1}/{stages}: bounds narrowed around the best: {ranges}")
                self._checkpoint(stage, space, optimizer, best, n_evals, n_failed, conv, history)
        except (KeyboardInterrupt, _Interrupted):
            interrupted = True
        finally:
            evaluator.close()
            if old_handler is not None:
                try:
                    signal.signal(signal.SIGTERM, old_handler)
                except ValueError:  # pragma: no cover
                    pass
        self.meta["timing"]["wall_s"] = wall0 + time.perf_counter() - t_session
        if interrupted:
            self.meta.update(status="interrupted", interrupted=_now())
            self._write_meta()
            self._live_report(final=True)
            if self.progress:
                self.progress(f"interrupted; resume with: tuner resume {self.dir}")
            return self._result("interrupted", best, n_evals, len(conv), "interrupted")
        self.meta.update(status="finished", finished=_now(), stop_reason=optimizer.stop_reason)
        extra: dict[str, Any] = {}
        if best["params"] is not None:
            extra = self._finalize(best, conv)
        self._write_meta()
        return self._result("finished", best, n_evals, len(conv), optimizer.stop_reason, extra)

    def _row(self, idx: int, stage: int, gen: int, i: int, p: dict[str, Any], r: EvalRecord) -> dict[str, Any]:
        ev = r.evaluation
        row = {"eval": idx, "stage": stage, "generation": gen, "index": i}
        row.update({k: _fmt(v) for k, v in p.items()})
        row.update(fitness=_fmt(float(ev.fitness)), status=ev.status, error=ev.error.replace("\n", " "),
                   seconds=f"{r.seconds:.6f}")
        row.update({k: _fmt(v) for k, v in ev.metrics.items()})
        return row

    def _checkpoint(self, stage, space, optimizer, best, n_evals, n_failed, conv, history) -> None:
        ck = {
            "version": 1,
            "stage": stage,
            "space": space.to_dict(),
            "optimizer": optimizer.state(),
            "best": best,
            "n_evals": n_evals,
            "n_failed": n_failed,
            "convergence": conv,
            "metric_names": history.metric_names,
        }
        atomic_write(self.dir / CHECKPOINT, pickle.dumps(ck, protocol=pickle.HIGHEST_PROTOCOL))

    def _write_best(self, best: dict[str, Any], space: Space) -> None:
        doc = {"params": best["params"], "fitness": best["fitness"], "metrics": best["metrics"],
               "found": {"stage": best["stage"], "generation": best["generation"], "eval": best["eval"]},
               "run": self.dir.name}
        atomic_write(self.dir / "best.yaml", _dump_yaml(doc))

    def _progress(self, stage, stages, optimizer, best, n, secs, n_failed) -> None:
        if not self.progress:
            return
        g, G = optimizer.generation, optimizer.generations
        rate = n / secs if secs > 0 else math.inf
        eta = ""
        if G:
            left = (G - g) + (stages - stage - 1) * G
            eta = f"  ETA {_dt.timedelta(seconds=round(left * secs))}"
        st = f"stage {stage + 1}/{stages} " if stages > 1 else ""
        fail = f"  failed {n_failed}" if n_failed else ""
        self.progress(f"{st}gen {g}/{G or '?'}  best {best['fitness']:.6g}  {rate:.1f} eval/s{eta}{fail}")

    def _finalize(self, best: dict[str, Any], conv: list[dict[str, Any]]) -> dict[str, Any]:
        from tuner.report import write_run_report

        extra: dict[str, Any] = {}
        finalize = getattr(self.objective, "finalize", None)
        if callable(finalize):
            try:
                extra = dict(finalize(self.dir, best["params"]) or {})
            except Exception as exc:  # reporting must not lose a finished run
                extra = {"finalize_error": f"{type(exc).__name__}: {exc}"}
                if self.progress:
                    self.progress(f"warning: the objective's report step failed: {exc}")
        if extra:
            doc = yaml.safe_load((self.dir / "best.yaml").read_text())
            doc["evaluation"] = _plain(extra)
            atomic_write(self.dir / "best.yaml", _dump_yaml(doc))
        try:
            write_run_report(self.dir, meta=self.meta)
        except Exception as exc:  # pragma: no cover - figures are a bonus, the results are on disk
            if self.progress:
                self.progress(f"warning: report not written: {type(exc).__name__}: {exc}")
        return extra

    def _live_report(self, final: bool = False) -> None:
        """report.html of the running run (throttled), or a last non-reloading one when ``final``."""
        from tuner.report import write_live_report

        try:
            write_live_report(self.dir, self.meta, final=final)
        except Exception as exc:  # pragma: no cover - a live view must not stop the run
            if self.progress:
                self.progress(f"warning: live report not written: {type(exc).__name__}: {exc}")

    def _result(self, status, best, n_evals, gens, reason, extra=None) -> RunResult:
        return RunResult(self.dir, status, dict(best["params"] or {}), float(best["fitness"]),
                         dict(best["metrics"]), n_evals, gens, reason, dict(extra or {}))


def _printer(quiet: bool) -> Callable[[str], None] | None:
    if quiet:
        return None
    return lambda msg: print(msg, file=sys.stderr, flush=True)


def _build(cfg: RunConfig):
    from objectives.registry import build_objective

    try:
        objective = build_objective(dict(cfg.objective), cfg.base_dir)
    except FileNotFoundError as exc:
        raise ConfigError(cfg.source, "objective", f"file not found: {exc.filename or exc}") from None
    except ValueError as exc:
        msg = str(exc)
        key, _, rest = msg.partition(": ")
        if key.startswith("objective") and rest:
            raise ConfigError(cfg.source, key, rest) from None
        raise ConfigError(cfg.source, "objective", msg) from None
    space = cfg.space(objective)
    if space.dim == 0:
        raise ConfigError(cfg.source, "parameters", "every parameter is fixed: nothing to tune")
    return objective, space


def run(cfg: RunConfig, run_dir: str | Path | None = None, quiet: bool = False,
        progress: Callable[[str], None] | None = None) -> RunResult:
    """Create a run directory for ``cfg`` and run it to the end (or until interrupted)."""
    objective, space = _build(cfg)
    r = Run.create(cfg, objective, space, Path(run_dir) if run_dir else None, progress or _printer(quiet))
    if r.progress:
        r.progress(f"run {r.dir}  ({cfg.optimizer.method}, {space.dim} parameters, "
                   f"{cfg.parallel.backend} x {cfg.parallel.n_jobs})")
    return r.execute()


def resume(run_dir: str | Path, quiet: bool = False, progress: Callable[[str], None] | None = None) -> RunResult:
    """Continue an interrupted run from its last checkpoint (a finished run is refused)."""
    run_dir = Path(run_dir)
    meta = read_meta(run_dir)
    if meta.get("status") == "finished":
        raise RunError(f"{run_dir}: already finished")
    raw = yaml.safe_load((run_dir / "config.yaml").read_text())
    source, base_dir = raw.pop("source", str(run_dir / "config.yaml")), Path(raw.pop("base_dir", run_dir))
    cfg = config_from_dict(raw, source=source, base_dir=base_dir)
    objective, space = _build(cfg)
    r = Run(cfg, run_dir, objective, space, progress or _printer(quiet))
    r.meta = meta
    ck_path = run_dir / CHECKPOINT
    ck = None
    if ck_path.exists():
        try:
            ck = pickle.loads(ck_path.read_bytes())
        except Exception as exc:
            raise RunError(f"{ck_path}: unreadable checkpoint ({exc})") from None
    else:  # killed before the first generation completed: start over in place
        (run_dir / "history.csv").unlink(missing_ok=True)
    if r.progress:
        done = ck["n_evals"] if ck else 0
        r.progress(f"resuming {run_dir} after {done} evaluations")
    return r.execute(ck)
