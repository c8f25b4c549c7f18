"""A job run over several seeds (``repeats: N``, ``tuner run --repeats N``): N ordinary runs, the spread over
them, one of them deployed.

Layout (the parent is a run directory; :mod:`tuner.rundir` describes it)::

    runs/<time>-<name>-<hex>/          config.yaml (with repeats: N), meta.json, repeats.json, best.yaml, report
        repeats/seed-<s>/               one run directory per seed, exactly what `tuner run JOB --seed s` writes

Repeat ``i`` of a job with seed ``s`` is the run of seed ``s + i`` (:data:`tuner.spread.SEED_RULE`): its
``config.yaml`` is that of a plain run of that seed (no ``repeats`` key), so its history equals the history of
``tuner run JOB --seed s+i``, serial or parallel, interrupted and resumed or not. The repeats run one after the
other, each with the job's ``parallel`` settings; they share one preflight (objective and space are built once).

After each repeat ends, ``repeats.json`` (:class:`tuner.records.Repeats`, computed by
:func:`tuner.spread.summarize`) is rewritten; when every repeat has finished, the chosen repeat's ``best.yaml``
becomes the parent's (its ``run`` names the repeat: ``repeats/seed-<s>``), so ``export``, ``evaluate``,
``show`` and :func:`tuner.load` read the parent as they read any run. A stop signal stops the repeat that runs
(it is resumable as any run) and the parent is marked interrupted; :func:`resume` continues every unfinished
repeat and starts the ones not begun, to the result of an uninterrupted run.
"""

from __future__ import annotations

import dataclasses
import datetime as _dt
import math
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

from tuner.config import RunConfig
from tuner.records import Best, Meta, RepeatEntry, Repeats, RunError, Timing, config_hash, dump_yaml
from tuner.rundir import RunDir, atomic_write
from tuner.setup import build as _build
from tuner.setup import run_config, worker_count
from tuner.spread import held_out_score, repeat_seeds, summarize

__all__ = ["run", "resume", "is_repeated", "repeat_config", "entry_of", "chosen_dir"]


def _now() -> str:
    return _dt.datetime.now(_dt.UTC).isoformat(timespec="seconds")


def is_repeated(run_dir: str | Path) -> bool:
    """True for the parent directory of a repeated run (its config says ``repeats: N > 1``)."""
    try:
        return RunDir(run_dir).repeat_count() > 1
    except (OSError, RunError):
        return False


def repeat_config(cfg: RunConfig, seed: int) -> RunConfig:
    """The plain run of ``cfg`` with seed ``seed``: what ``tuner run JOB --seed seed`` runs (no ``repeats``)."""
    raw = {k: v for k, v in cfg.raw.items() if k != "repeats"}
    raw["seed"] = int(seed)
    return dataclasses.replace(cfg, seed=int(seed), repeats=1, raw=raw)


def chosen_dir(run_dir: str | Path) -> Path | None:
    """The run directory of a repeated run's chosen repeat (None before one is chosen, or for a single run)."""
    return RunDir(run_dir).chosen_repeat()


def entry_of(parent: RunDir, index: int, seed: int) -> RepeatEntry:
    """What repeat ``index`` (seed ``seed``) recorded so far: its status and counts (``meta.json``) and, once it
    has one, its best (``best.yaml``: fitness, params, held-out score, defaults' fitness)."""
    name = parent.repeat_name(seed)
    rd = RunDir(parent.path / name)
    if not rd.file("meta.json").exists():
        return RepeatEntry(index, seed, name, "not started")
    meta = rd.meta()
    entry = RepeatEntry(index, seed, name, meta.status, meta.n_evals, meta.n_failed,
                        wall_s=float(meta.timing.wall_s or 0.0))
    if not rd.has_best():
        return entry
    best = rd.best()
    held = held_out_score(best.evaluation)
    dflt = best.evaluation.get("defaults_fitness")
    dflt = float(dflt) if isinstance(dflt, (int, float)) and not isinstance(dflt, bool) else None
    return dataclasses.replace(entry, fitness=float(best.fitness), params=dict(best.params),
                               held_out=None if held is None else held[1], held_out_key="" if held is None else held[0],
                               defaults_fitness=dflt)


def _summarize(parent: RunDir, seeds: list[int], space: Any) -> Repeats:
    rep = summarize(seeds, [entry_of(parent, i, s) for i, s in enumerate(seeds)], space)
    parent.write_repeats(rep)
    if rep.chosen_entry is not None:  # the parent deploys the chosen repeat: its best, naming where it came from
        best = RunDir(parent.path / rep.chosen_entry.run).best()
        atomic_write(parent.file("best.yaml"), dump_yaml(dataclasses.replace(best, run=rep.chosen_entry.run).to_doc()))
    return rep


def _meta_totals(meta: Meta, rep: Repeats, status: str, **kw: Any) -> Meta:
    n_evals = sum(e.n_evals for e in rep.entries)
    n_failed = sum(e.n_failed for e in rep.entries)
    wall = sum(e.wall_s for e in rep.entries)
    return meta.replace(status=status, n_evals=n_evals, n_failed=n_failed,
                        timing=dataclasses.replace(meta.timing or Timing(), wall_s=wall), **kw)


def _drive(cfg: RunConfig, parent: RunDir, meta: Meta, built: tuple[Any, Any], printer: Callable[[str], None] | None,
           report: bool, on_generation: Callable[[Any], None] | None = None) -> Any:
    from tuner import run as run_mod

    objective, space = built
    seeds = repeat_seeds(cfg.seed, cfg.repeats)
    parent.write_meta(meta.replace(status="running", started=meta.started or _now()))
    for i, seed in enumerate(seeds):
        sub = parent.path / parent.repeat_name(seed)
        entry = entry_of(parent, i, seed)
        if entry.status == "finished" or entry.status == "failed":
            continue
        if printer:
            printer(f"repeat {i + 1}/{len(seeds)}: seed {seed} ({parent.repeat_name(seed)})")
        if entry.status == "not started" and not (sub / "meta.json").exists():
            sub.parent.mkdir(parents=True, exist_ok=True)
            res = run_mod.run(repeat_config(cfg, seed), run_dir=sub, progress=printer, quiet=printer is None,
                              report=False, built=built, resume_as=parent.path, on_generation=on_generation)
        else:
            res = run_mod.resume(sub, progress=printer, quiet=printer is None, report=False, resume_as=parent.path)
        rep = _summarize(parent, seeds, space)
        if res.status == "interrupted":
            parent.write_meta(_meta_totals(parent.meta(), rep, "interrupted", interrupted=_now()))
            return _result(parent, rep, "interrupted", "interrupted")
    rep = _summarize(parent, seeds, space)
    status = "finished" if rep.chosen is not None else "failed"
    parent.write_meta(_meta_totals(parent.meta(), rep, status, finished=_now(),
                                   stop_reason=f"{len(seeds)} repeats"))
    if report and status == "finished":
        from tuner.report import write_run_report

        try:
            write_run_report(parent.path)
        except Exception as exc:  # noqa: BLE001 - the run is complete; a report failure must not hide it
            if printer:
                printer(f"report not written ({type(exc).__name__}: {exc}); `tuner report {parent.path}` retries")
    return _result(parent, rep, status, f"{len(seeds)} repeats")


def _result(parent: RunDir, rep: Repeats, status: str, reason: str) -> Any:
    from tuner.run import RunResult

    best: Best | None = parent.best() if rep.chosen is not None and parent.has_best() else None
    n_evals = sum(e.n_evals for e in rep.entries)
    return RunResult(parent.path, status, best, n_evals, 0, reason, {}, rep)


def run(cfg: RunConfig, run_dir: str | Path | None = None, quiet: bool = False,
        progress: Callable[[str], None] | None = None, report: bool = True,
        on_generation: Callable[[Any], None] | None = None) -> Any:
    """Run the ``cfg.repeats`` seeds of a job into one parent run directory (module docstring); returns a
    :class:`tuner.run.RunResult` whose ``best`` is the chosen repeat's and whose ``repeats`` is the spread."""
    from tuner import run as run_mod

    if cfg.repeats < 2:
        return run_mod.run(cfg, run_dir=run_dir, quiet=quiet, progress=progress, report=report,
                           on_generation=on_generation)
    built = _build(cfg)
    objective, space = built
    n_jobs, notes = worker_count(cfg, space)
    printer = progress or (None if quiet else (lambda msg: print(msg, file=sys.stderr, flush=True)))
    parent = RunDir(run_mod.default_run_dir(cfg) if run_dir is None else run_dir)
    if parent.path.exists() and not parent.path.is_dir():
        raise RunError(f"{parent.path}: exists and is not a directory")
    with parent.lock():
        run_mod.check_unstarted(parent, printer)
        meta = run_mod.new_meta(cfg, parent.write_config(run_mod.resolved_config(cfg, space)), n_jobs, notes)
        parent.write_meta(meta)
        if printer:
            printer(f"run {parent.path}  ({cfg.repeats} repeats, seeds {cfg.seed} .. {cfg.seed + cfg.repeats - 1}; "
                    f"{cfg.optimizer.method}, {space.dim} parameters, {cfg.parallel.backend} x {n_jobs})")
        return _drive(cfg, parent, meta, built, printer, report, on_generation)


def resume(run_dir: str | Path, quiet: bool = False, progress: Callable[[str], None] | None = None,
           report: bool = True) -> Any:
    """Continue a repeated run: every unfinished repeat is resumed, the ones not begun are started."""
    parent = RunDir(run_dir)
    printer = progress or (None if quiet else (lambda msg: print(msg, file=sys.stderr, flush=True)))
    with parent.lock():
        meta = parent.meta() if parent.file("meta.json").exists() else None
        if meta is not None and meta.status == "finished":
            raise RunError(f"{parent.path}: already finished")
        cfg = run_config(parent, parent.check_config(meta) if meta is not None else None)
        built = _build(cfg)
        if meta is None:
            n_jobs, notes = worker_count(cfg, built[1])
            from tuner.run import new_meta

            meta = new_meta(cfg, config_hash(parent.config()), n_jobs, notes)
        if printer:
            printer(f"resuming {parent.path}: {cfg.repeats} repeats")
        return _drive(cfg, parent, meta, built, printer, report)


def fitness_text(rep: Repeats) -> str:
    """One line: the median best fitness and its range over the seeds."""
    f = rep.fitness
    if f is None:
        return "-"
    return f"{f.median:.6g} (median of {f.n}; {f.low:.6g} .. {f.high:.6g})" if not math.isnan(f.median) else "-"


__all__ += ["fitness_text"]
