"""A run's life: create its directory, run the loop generation by generation, record, resume, finish.

The run directory and its files belong to :mod:`tuner.rundir`; the loop (ask, evaluate, tell) to
:func:`tuner.loop.minimize`. This module connects them: it writes each generation's history rows,
then ``best.yaml``, then ``checkpoint.json`` (the count of rows that are complete generations), then
``meta.json``; a resumed run cuts the history back to what the checkpoint covers, recreates the
optimiser from the run seed and replays ``tell`` with the recorded fitness of those rows (no state
is unpickled; an edited history is detected because the replayed optimiser asks other points), then
carries on. A run killed at any moment therefore resumes to exactly the result of an uninterrupted
run. The run directory is locked (``flock``) for the life of a run or a resume.
"""

from __future__ import annotations

import dataclasses
import datetime as _dt
import math
import os
import platform
import secrets
import socket
import subprocess
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from tuner import signals as stop_signals
from tuner._version import __version__
from tuner.config import RunConfig
from tuner.deployment import attach_deployment, load_best
from tuner.evaluate import sigint_count
from tuner.loop import BestPoint, Generation, SeededCall, minimize
from tuner.objective import hook
from tuner.records import Best, Checkpoint, HistoryRow, Meta, Repeats, RunError, Timing, config_hash, plain, read_back
from tuner.replay import Replay as _Replay
from tuner.rundir import RunDir, atomic_write
from tuner.selection import select_best
from tuner.setup import LiveMap, new_optimizer, run_config, worker_count
from tuner.setup import build as _build  # the old name, used by benchmarks
from tuner.space import Space
from tuner.validation import cv_deploys_defaults, validate_run

__all__ = ["RunResult", "run", "resume", "atomic_write", "read_meta", "load_best", "new_meta", "resolved_config",
           "RunError"]


@dataclass(frozen=True)
class RunResult:
    """What a finished (or interrupted) run produced.

    Attributes
    ----------
    run_dir : Path
        The run directory.
    status : str
        ``meta.json``'s status (``finished``, ``interrupted``, ...).
    best : BestPoint or None
        The best successful evaluation (as ``best.yaml`` holds it); None when none succeeded.
    n_evals, generations : int
        Evaluations and generations done.
    stop_reason : str
        Why the run stopped.
    extra : dict
        What the objective's finalisation returned.
    repeats : tuner.records.Repeats or None
        A repeated run's spread over its seeds (``repeats.json``; :mod:`tuner.repeats`); None for one run.
    """

    run_dir: Path
    status: str
    best: BestPoint | None
    n_evals: int
    generations: int
    stop_reason: str
    extra: dict[str, Any] = field(default_factory=dict)
    repeats: Repeats | None = None

    @property
    def best_params(self) -> dict[str, Any]:
        """Physical values of the best point (empty when none succeeded)."""
        return dict(self.best.params) if self.best else {}

    @property
    def best_fitness(self) -> float:
        """Its fitness (inf when none succeeded)."""
        return self.best.fitness if self.best else math.inf

    @property
    def best_metrics(self) -> dict[str, Any]:
        """Its metrics (empty when none succeeded)."""
        return dict(self.best.metrics) if self.best else {}


def read_meta(run_dir: Path) -> dict[str, Any]:
    """``meta.json`` of a run directory as a plain dict (typed: :meth:`tuner.rundir.RunDir.meta`)."""
    return RunDir(run_dir).meta().to_dict()


def _git_commit() -> str:
    root = Path(__file__).resolve().parents[1]
    if not (root / ".git").exists():  # an installed package: a repository around site-packages is not ours
        return ""
    try:
        out = subprocess.run(["git", "-C", str(root), "rev-parse", "HEAD"], capture_output=True, text=True,
                             timeout=5)
        return out.stdout.strip() if out.returncode == 0 else ""
    except (OSError, subprocess.SubprocessError):
        return ""


#: module name -> distribution whose version meta.json records
_VERSIONED = {"numpy": "numpy", "scipy": "scipy", "numba": "numba", "joblib": "joblib", "pandas": "pandas",
              "cma": "cma", "yaml": "PyYAML"}


def _versions() -> dict[str, str]:
    """Versions of the core packages, read from their metadata: importing pandas and cma only to ask cost
    about 100 MB of resident memory before the first evaluation (the Madgwick 16-trial run with 2 threads
    peaked at 534 MB, 472 MB without)."""
    from importlib.metadata import PackageNotFoundError, version

    out = {"python": platform.python_version()}
    for mod, dist in _VERSIONED.items():
        try:
            out[mod] = version(dist)
        except PackageNotFoundError:  # pragma: no cover
            out[mod] = ""
    out["tuner"] = __version__
    return out


def _now() -> str:
    return _dt.datetime.now(_dt.UTC).strftime("%Y-%m-%dT%H:%M:%SZ")


def _preload_report() -> None:
    """Import the live report's modules (pandas among them) before the first generation. Imported on the
    first generation's report instead, a Ctrl-C landing inside that import (it takes about a second)
    leaves the modules half-initialised, and the interrupted run could not write its final report."""
    try:
        import tuner.report  # noqa: F401
    except Exception:  # the report is a view: _live_report warns when it cannot be written
        pass


class _Interrupted(BaseException):
    """A stop signal whose KeyboardInterrupt was swallowed on the way (never a recorded failure)."""




class Run:
    """Drives one run directory. Use :func:`run` and :func:`resume`."""

    def __init__(self, cfg: RunConfig, rd: RunDir, objective: Any, space: Space,
                 progress: Callable[[str], None] | None, meta: Meta, n_jobs: int,
                 on_generation: Callable[[Generation], None] | None = None, report: bool = True,
                 resume_as: Path | None = None):
        self.cfg, self.rd, self.dir = cfg, rd, rd.path
        self.report, self.resume_as = report, resume_as or rd.path  # what `tuner resume` continues it through
        self.objective, self.base_space, self.progress = objective, space, progress
        self.meta, self.n_jobs, self.on_generation = meta, n_jobs, on_generation or (lambda g: None)
        self.best: Best | None = None

    # --- optimiser of a stage -----------------------------------------------------------------
    def _stage_space(self, stage: int, best_params: dict[str, Any]) -> Space:
        space = self.base_space
        for _ in range(stage):
            space = space.narrowed(best_params, self.cfg.optimizer.refine.shrink)
        return space

    def _new_optimizer(self, stage: int, space: Space, x0: np.ndarray | None):
        return new_optimizer(self.cfg, stage, space, x0, self.objective)

    def _write_meta(self, **kw: Any) -> None:
        self.meta = self.meta.replace(**kw)
        self.rd.write_meta(self.meta)

    # --- main loop ----------------------------------------------------------------------------
    def execute(self, replay_rows: list[dict[str, str]] | None = None) -> RunResult:
        """Run (or replay, then continue) to the end; SIGTERM and SIGHUP act as Ctrl-C meanwhile."""
        old_handlers = stop_signals.install()
        try:
            return self._execute(replay_rows)
        finally:
            stop_signals.restore(old_handlers)

    def _execute(self, replay_rows: list[dict[str, str]] | None) -> RunResult:
        stages = self.cfg.optimizer.refine.stages
        history = self.rd.history(self.base_space.names, self.meta.config_hash)
        live = LiveMap(self.cfg, self.n_jobs)
        replay = _Replay(list(replay_rows or []), self.base_space.names, live, history.path)
        t = self.meta.timing
        self._write_meta(status="running", started=self.meta.started or _now(), backend_detail=live.describe(),
                         timing=Timing(t.wall_s, t.objective_s, t.sessions + 1))
        t_session, wall0 = time.perf_counter(), self.meta.timing.wall_s
        state = {"gens": 0, "t0": time.perf_counter()}
        sigints = sigint_count()

        def on_generation(g: Generation) -> None:
            state["gens"] += 1
            best = self._best_doc(g)
            if g.first_eval < len(replay.rows):  # replayed from the history: nothing new to write
                if g.stats.n_evals == len(replay.rows):
                    self.best = best
                    if best is not None:
                        self.rd.write_best(best)
                    if self.progress:
                        self.progress(f"replayed {g.stats.n_evals} recorded evaluations")
                return
            history.append([self._row(g, i) for i in range(len(g.records))])
            self.best = best
            if best is not None:
                self.rd.write_best(best)
            self.rd.write_checkpoint(Checkpoint(g.stats.n_evals, g.stage, state["gens"]))
            tm = self.meta.timing
            self._write_meta(n_evals=g.stats.n_evals, n_failed=g.n_failed, generations=state["gens"],
                             timing=Timing(wall0 + time.perf_counter() - t_session,
                                           tm.objective_s + sum(r.seconds for r in g.records), tm.sessions))
            if not replay.replaying and self.report:
                self._live_report()
            now = time.perf_counter()
            self._progress(g, stages, now - state["t0"])
            self.on_generation(g)  # after the generation is on disk (tuner.api's callback)
            state["t0"] = now
            if sigint_count() != sigints:  # a Ctrl-C whose KeyboardInterrupt was swallowed on the way
                raise _Interrupted()

        stage, space, n_evals, n_failed, best, interrupted = 0, self.base_space, 0, 0, None, False
        optimizer = self._new_optimizer(0, space, None)
        if self.progress and hasattr(optimizer, "describe"):  # e.g. the method `auto` picked
            self.progress(f"optimizer: {optimizer.describe()}")
        try:
            if self.report:
                _preload_report()
            while True:
                res = minimize(SeededCall(self.objective), space, optimizer, replay, on_generation,
                               seed=self.cfg.seed, stage=stage, first_eval=n_evals, best=best, n_failed=n_failed)
                best, n_evals, n_failed = res.best, res.n_evals, res.n_failed
                if stage + 1 >= stages or best is None:
                    break
                stage += 1
                space = self._stage_space(stage, best.params)
                optimizer = self._new_optimizer(stage, space, space.encode(
                    {k: v for k, v in best.params.items() if k in space.free_names}))
                if self.progress and not replay.replaying:
                    ranges = ", ".join(f"{p.name} [{p.low:.4g}, {p.high:.4g}]" for p in space.free)
                    self.progress(f"stage {stage + 1}/{stages}: bounds narrowed around the best: {ranges}")
        except (KeyboardInterrupt, _Interrupted):
            interrupted = True
        finally:
            live.close()
        try:
            return self._conclude(optimizer, replay, history, interrupted, n_evals, n_failed, state, wall0, t_session)
        except KeyboardInterrupt:  # a stop signal during the selection, the report step or the CV after a run
            self._write_meta(status="interrupted", interrupted=_now())
            if self.progress:
                self.progress(f"interrupted; resume with: tuner resume {self.resume_as}")
            return self._result("interrupted", n_evals, state["gens"], "interrupted")

    def _conclude(self, optimizer, replay, history, interrupted: bool, n_evals: int, n_failed: int,
                  state: dict[str, Any], wall0: float, t_session: float) -> RunResult:
        """After the optimiser stopped: the interrupted record, or selection, report step, CV and report."""
        if replay.replaying and not interrupted:
            raise RunError(f"{history.path}: {len(replay.rows)} rows recorded, but the run ends after "
                           f"{n_evals}; the history does not belong to this config")
        tm = self.meta.timing
        timing = Timing(wall0 + time.perf_counter() - t_session, tm.objective_s, tm.sessions)
        if interrupted:
            self._write_meta(status="interrupted", interrupted=_now(), timing=timing)
            if self.report:
                self._live_report(final=True)
            if self.progress:
                self.progress(f"interrupted; resume with: tuner resume {self.resume_as}")
            return self._result("interrupted", n_evals, state["gens"], "interrupted")
        extra = self._finish() if self.best is not None else {}
        # a run whose every evaluation failed has no result: it ends "failed", not "finished"
        status = "finished" if self.best is not None or not n_evals else "failed"
        reason = optimizer.stop_reason if status == "finished" else f"every one of {n_evals} evaluations failed"
        self._write_meta(status=status, finished=_now(), stop_reason=reason, timing=timing,
                         n_evals=n_evals, n_failed=n_failed, generations=state["gens"])
        if self.best is not None and self.report:
            self._report()  # after meta.json: the report shows the final status
        return self._result(status, n_evals, state["gens"], reason, extra)

    def _best_doc(self, g: Generation) -> Best | None:
        b = g.best
        if b is None:
            return None
        return Best(plain(b.params), b.fitness, read_back(b.metrics), b.stage, b.generation, b.eval, self.dir.name)

    def _row(self, g: Generation, i: int) -> HistoryRow:
        r, ev = g.records[i], g.records[i].evaluation
        return HistoryRow(g.first_eval + i, g.stage, g.generation, i, g.params[i], ev.fitness, ev.status, ev.error,
                          r.seconds, ev.metrics)

    def _progress(self, g: Generation, stages: int, secs: float) -> None:
        if not self.progress:
            return
        opt = g.optimizer
        gen, G, n = opt.generation, opt.generations, len(g.records)
        rate = n / secs if secs > 0 else math.inf
        later = stages - g.stage - 1  # stages still to come, each with the same budget
        left_s = []  # the time each budget still needs at this generation's pace; the first one spent ends the run
        if G:
            left_s.append(((G - gen) + later * G) * secs)
        cap = getattr(opt, "max_evals", None)
        if cap and n:
            left_s.append((max(cap - opt.n_evals, 0) + later * cap) * secs / n)
        eta = f"  ETA {_dt.timedelta(seconds=round(min(left_s)))}" if left_s else ""
        st = f"stage {g.stage + 1}/{stages} " if stages > 1 else ""
        head = f"gen {gen}/{G}" if G else f"gen {gen}"
        if cap:
            head += f"  evals {opt.n_evals}/{cap}"
        fail = f"  failed {g.n_failed}" if g.n_failed else ""
        self.progress(f"{st}{head}  best {g.stats.best:.6g}  {rate:.1f} eval/s{eta}{fail}")

    def _finish(self) -> dict[str, Any]:
        """The end of a finished run: the final choice on a held-out fold (``validation.select``), the
        objective's report step, the defaults' scores and the cross-validation (``validation.cv``); then
        ``best.yaml``, derived from the history with all their results, written once. Returns the report
        step's results."""
        assert self.best is not None
        selection = None
        if self.cfg.validation.select is not None:
            self.best, selection = select_best(self.cfg, self.rd, self.best, self.base_space.names, self.progress)
        extra = self._finalize()
        # the defaults' scores, the CV into the run directory: their numbers into best's evaluation
        self.best = validate_run(self.cfg, self.rd, self.best, selection, self.progress, self.objective,
                                 self.base_space)
        dflt = cv_deploys_defaults(self.cfg, self.best, self.objective, self.base_space)
        if dflt is not None:  # the CV says tuning does worse held out than the defaults: deploy them
            ev = dict(dflt.evaluation)
            self.best = dflt
            extra = self._finalize()  # their deployment and the objective's report step
            self.best = dataclasses.replace(self.best, evaluation=plain({**ev, **self.best.evaluation}))
            if self.progress:
                self.progress(f"cross-validation: the defaults score {ev['defaults_cv_fitness']:.4g} on the held-out "
                              f"folds, the tuning {ev['cv_fitness']:.4g}: the run deploys the defaults")
        self.rd.write_best(self.best)
        return extra

    def _finalize(self) -> dict[str, Any]:
        """The complete tuned system (the deployment) and the objective's report step, both into ``self.best``."""
        assert self.best is not None
        self.best = attach_deployment(self.best, self.objective, self.base_space)
        extra: dict[str, Any] = {}
        finalize = getattr(self.objective, "finalize", None)
        if callable(finalize):
            try:
                extra = dict(finalize(self.dir, self.best.params) or {})
            except Exception as exc:  # reporting must not lose a finished run
                extra = {"finalize_error": f"{type(exc).__name__}: {exc}"}
                if self.progress:
                    self.progress(f"warning: the objective's report step failed: {exc}")
        if extra:
            self.best = dataclasses.replace(self.best, evaluation=plain(extra))
        return extra

    def _report(self) -> None:
        from tuner.report import write_run_report

        try:
            write_run_report(self.dir, meta=self.meta.to_dict())
        except Exception as exc:  # pragma: no cover - figures are a bonus, the results are on disk
            if self.progress:
                self.progress(f"warning: report not written: {type(exc).__name__}: {exc}")

    def _live_report(self, final: bool = False) -> None:
        """report.html of the running run (throttled), or a last non-reloading one when ``final``."""
        try:  # the import too: a Ctrl-C that cut its first import short leaves pandas half-initialised
            from tuner.report import write_live_report

            write_live_report(self.dir, self.meta.to_dict(), final=final)
        except Exception as exc:  # pragma: no cover - a live view must not stop the run
            if self.progress:
                self.progress(f"warning: live report not written: {type(exc).__name__}: {exc}")

    def _result(self, status: str, n_evals: int, gens: int, reason: str, extra=None) -> RunResult:
        return RunResult(self.dir, status, self.best, n_evals, gens, reason, dict(extra or {}))


def _printer(quiet: bool) -> Callable[[str], None] | None:
    return None if quiet else (lambda msg: print(msg, file=sys.stderr, flush=True))


def resolved_config(cfg: RunConfig, space: Space) -> dict[str, Any]:
    """What ``config.yaml`` of a run of ``cfg`` on ``space`` holds: the resolved config, its space, its origin."""
    resolved = dict(cfg.raw)
    resolved["parameters"] = space.to_dict()
    resolved["source"] = str(cfg.source)
    resolved["base_dir"] = str(cfg.base_dir)
    return resolved


def new_meta(cfg: RunConfig, chash: str, n_jobs: int, notes: list[str]) -> Meta:
    """``meta.json`` of a run of ``cfg`` just created (config hash ``chash``, ``n_jobs`` workers, ``notes``)."""
    return Meta(status="created", name=cfg.name, seed=cfg.seed, created=_now(), config_source=str(cfg.source),
                config_hash=chash, versions=_versions(), git_commit=_git_commit(), host=socket.gethostname(),
                cpu_count=os.cpu_count(), backend=cfg.parallel.backend, n_jobs=n_jobs,
                n_jobs_requested=cfg.parallel.n_jobs, optimizer=cfg.optimizer.method, notes=tuple(notes))


#: files a run directory may hold when it was created but killed before ``meta.json`` existed
UNSTARTED = {"config.yaml", ".config.json", ".lock"}


def default_run_dir(cfg: RunConfig) -> Path:
    """``<output>/<UTC time>-<name>-<6 hex>``: where a run of ``cfg`` goes unless told."""
    stamp = _dt.datetime.now(_dt.UTC).strftime("%Y%m%dT%H%M%SZ")
    out = Path(cfg.output)
    return (out if out.is_absolute() else Path.cwd() / out) / f"{stamp}-{cfg.name}-{secrets.token_hex(3)}"


def check_unstarted(rd: RunDir, printer: Callable[[str], None] | None) -> None:
    """Refuse a directory that holds more than a run killed before it started (call it holding the lock)."""
    rd.remove_tmp()
    present = {p.name for p in rd.path.iterdir()}
    if present - UNSTARTED:
        raise RunError(f"{rd.path}: exists and is not empty; use `tuner resume {rd.path}` or another directory")
    if present & {"config.yaml", ".config.json"} and printer:
        printer(f"reusing {rd.path}: it was created but killed before the run started (no meta.json)")


def _store_fingerprint(objective: Any, rd: RunDir) -> list[str]:
    """Write the objective's ``fingerprint`` of its tuning data into the run directory; its summary lines."""
    fn = hook(objective, "fingerprint")
    if fn is None:
        return []
    try:
        doc = dict(fn() or {})
    except Exception as exc:  # noqa: BLE001 - a statistic must not stop the run it describes
        return [f"note: no data fingerprint ({type(exc).__name__}: {exc})"]
    if doc:
        rd.write_fingerprint(doc)
    return [str(x) for x in doc.get("summary", [])]


def run(cfg: RunConfig, run_dir: str | Path | None = None, quiet: bool = False,
        progress: Callable[[str], None] | None = None,
        on_generation: Callable[[Generation], None] | None = None, report: bool = True,
        built: tuple[Any, Space] | None = None, resume_as: Path | None = None) -> RunResult:
    """Create a run directory for ``cfg`` and run it to the end (or until interrupted); ``on_generation(g)``
    is called after each generation is written. Everything that can be refused (objective, parameters,
    optimiser options) is built before the directory is created, so a bad config leaves nothing behind.
    ``report=False`` leaves out the report, the live view during the run as well as the final one (report.md,
    report.html and their figures; ``tuner report RUN_DIR`` writes it later); the records and best.yaml are
    written as always.

    One run: a job with ``repeats: N > 1`` is :func:`tuner.repeats.run`'s (a :class:`RunError` here).
    ``built``: the ``(objective, space)`` :func:`tuner.setup.build` made of ``cfg`` already (the repeats of a
    job share one preflight); ``resume_as``: the directory the interrupted message names (a repeat's parent).
    """
    if cfg.repeats > 1:
        raise RunError(f"{cfg.source}: repeats: {cfg.repeats} runs of one job are tuner.repeats.run's "
                       "(`tuner run` and tuner.tune call it); tuner.run.run runs one")
    objective, space = built if built is not None else _build(cfg)
    n_jobs, notes = worker_count(cfg, space)
    printer = progress or _printer(quiet)
    rd = RunDir(default_run_dir(cfg) if run_dir is None else run_dir)
    if rd.path.exists() and not rd.path.is_dir():
        raise RunError(f"{rd.path}: exists and is not a directory")
    with rd.lock():
        check_unstarted(rd, printer)
        meta = new_meta(cfg, rd.write_config(resolved_config(cfg, space)), n_jobs, notes)
        rd.write_meta(meta)
        r = Run(cfg, rd, objective, space, printer, meta, n_jobs, on_generation, report, resume_as)
        fingerprint = _store_fingerprint(objective, rd)
        if printer:
            printer(f"run {rd.path}  ({cfg.optimizer.method}, {space.dim} parameters, "
                    f"{cfg.parallel.backend} x {n_jobs})")
            for note in notes:
                printer(f"note: {note}")
            for line in fingerprint:
                printer(line)
        return r.execute()


def resume(run_dir: str | Path, quiet: bool = False, progress: Callable[[str], None] | None = None,
           report: bool = True, resume_as: Path | None = None) -> RunResult:
    """Continue an interrupted (or killed) run: replay its recorded generations, then go on; ``report=False``
    writes no report, as for :func:`run` (and ``resume_as`` as there). A repeated run is
    :func:`tuner.repeats.resume`'s.

    A finished run, a run in use by another process, a changed ``config.yaml`` and a legacy pickled
    checkpoint are refused with :class:`RunError`. A directory killed before ``meta.json`` existed is
    started from the beginning with its ``config.yaml``.
    """
    rd = RunDir(run_dir)
    printer = progress or _printer(quiet)
    if not rd.path.is_dir():
        raise RunError(f"{rd.path}: not a run directory (no such directory)")
    with rd.lock():
        meta: Meta | None = None
        if not rd.is_run() and not rd.file("config.yaml").is_file():
            raise RunError(f"{rd.path}: no meta.json and no config.yaml (killed before the run started, or not a "
                           f"run directory); start it again with `tuner run CONFIG --run-dir {rd.path}`")
        if rd.is_run() or rd.file("checkpoint.json").exists() or rd.file("history.csv").exists():
            meta = rd.meta()  # a run that got that far had a meta.json: its loss is an error, not a restart
        if meta is not None and meta.status == "finished":
            raise RunError(f"{rd.path}: already finished")
        if meta is not None and meta.status == "failed":
            raise RunError(f"{rd.path}: already ended, every evaluation failed ({meta.stop_reason}); fix the objective "
                           "and start the job again")
        ck = rd.checkpoint()
        cfg = run_config(rd, rd.check_config(meta) if meta is not None else None)
        if cfg.repeats > 1:
            raise RunError(f"{rd.path}: a repeated run ({cfg.repeats} seeds): tuner.repeats.resume continues it "
                           "(`tuner resume` calls it)")
        objective, space = _build(cfg)
        n_jobs, notes = worker_count(cfg, space)
        removed = rd.remove_tmp()
        if printer and removed:
            printer(f"removed {len(removed)} temporary file(s) left by the kill: {', '.join(sorted(removed))}")
        if meta is None:
            if printer:
                printer(f"{rd.path}: no meta.json (killed before the run started): starting it from the beginning")
            meta = new_meta(cfg, config_hash(rd.config()), n_jobs, notes)
        meta = meta.replace(n_jobs=n_jobs, notes=tuple(dict.fromkeys((*meta.notes, *notes))))
        if ck is None:  # killed before the first generation completed: start over in place
            for name in ("history.csv", "best.yaml"):
                rd.file(name).unlink(missing_ok=True)
            rows: list[dict[str, str]] = []
        else:
            rows = rd.history(space.names, meta.config_hash).truncate(ck.n_evals)
        r = Run(cfg, rd, objective, space, printer, meta, n_jobs, report=report, resume_as=resume_as)
        if printer:
            printer(f"resuming {rd.path} after {len(rows)} evaluations")
        return r.execute(rows)
