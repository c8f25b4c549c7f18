"""Setting up a tuning from its config: the objective, the space, the optimiser of a stage, the number of
workers and the map that evaluates a generation.

One place for what a run (:mod:`tuner.run`), a cross-validation (:mod:`tuner.cv`) and the benchmarks
build from a :class:`~tuner.config.RunConfig`, so they agree: the same error lines for a bad objective
or bad optimiser options, the same optimiser seeds (``SeedSequence([run seed, stage])``) and one worker
rule (:func:`worker_count`: at most the optimiser's population, computed once by :func:`population`, and, for
local pools, the CPU count).
"""

from __future__ import annotations

import dataclasses
import os
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from tuner.config import ConfigError, RunConfig, check_optimizer_options, config_from_dict, optimizer_options
from tuner.evaluate import EvalRecord, Evaluator, TimedObjective
from tuner.objective import hook
from tuner.optimizers import OptionError, get_optimizer
from tuner.rundir import RunDir
from tuner.space import Space

__all__ = ["run_config", "run_origin", "run_objective", "build_objective", "build", "new_optimizer", "start_point",
           "population", "worker_count", "LiveMap"]


def run_config(rd: RunDir, raw: dict[str, Any] | None = None) -> RunConfig:
    """The :class:`RunConfig` a run directory was started with (its ``config.yaml``, or ``raw``, that file
    as already read and checked): the one way back from a run directory to its config, so its objective
    and space are those of :func:`build_objective` and ``cfg.space``. Relative paths resolve against the
    directory the config was loaded from (recorded as ``base_dir``), else the run directory."""
    raw = dict(rd.config() if raw is None else raw)
    source, base_dir = raw.pop("source", str(rd.file("config.yaml"))), Path(raw.pop("base_dir", rd.path))
    cfg = config_from_dict(raw, source=source, base_dir=base_dir)
    return dataclasses.replace(cfg, origin=run_origin(rd.path))


def run_origin(run_dir: Path) -> Path:
    """The directory whose content a command handed ``run_dir`` must not load code from: the run directory, for
    a sweep's job (``SWEEP/jobs/JOB``) the whole sweep directory, for a repeat (``RUN/repeats/seed-<s>``) its
    parent's origin."""
    run_dir = Path(run_dir).resolve()
    if run_dir.parent.name == "repeats" and os.path.lexists(run_dir.parent.parent / "config.yaml"):
        return run_origin(run_dir.parent.parent)  # a repeat of a repeated run: its parent's origin
    sweep = run_dir.parent.parent
    if run_dir.parent.name == "jobs" and os.path.lexists(sweep / "sweep.yaml"):
        return sweep
    return run_dir


def run_objective(rd: RunDir) -> tuple[RunConfig, Any, Space]:
    """A run directory's config, objective (as registered, no preflight, no data loaded) and search space."""
    cfg = run_config(rd)
    objective = build_objective(cfg)
    return cfg, objective, cfg.space(objective)


def build_objective(cfg: RunConfig) -> Any:
    """The objective of ``cfg`` as registered (no preflight); a refused one is a :class:`ConfigError`."""
    from tuner.registry import build_objective as _from_registry
    from tuner.trust import code_outside

    try:
        with code_outside(cfg.origin):  # a config read from a run directory: none of its code from there
            return _from_registry(dict(cfg.objective), cfg.base_dir)
    except FileNotFoundError as exc:
        raise ConfigError(cfg.source, "objective", f"file not found: {exc.filename or exc}") from None
    except ValueError as exc:
        msg = str(exc)
        key, _, rest = msg.partition(": ")
        if key.startswith("objective") and rest:
            raise ConfigError(cfg.source, key, rest) from None
        raise ConfigError(cfg.source, "objective", msg) from None


def build(cfg: RunConfig) -> tuple[Any, Space]:
    """Objective and space a run of ``cfg`` tunes, checked by :func:`tuner.preflight.preflight` (bad data,
    names, a failing default evaluation are :class:`ConfigError` before anything is written). With
    ``validation.select`` the objective is the tuning side of the held-out split; with
    ``objective.timeout_s`` it is wrapped in :class:`tuner.evaluate.TimedObjective`."""
    from tuner.preflight import check_cv_folds, preflight
    from tuner.registry import say_imports
    from tuner.selection import tuning_objective

    say_imports(cfg.objective, cfg.source)
    objective = build_objective(cfg)
    check_cv_folds(cfg, objective)  # an impossible `validation.cv` is refused now, not after the tuning
    if cfg.validation.select is not None:  # tune without the held-out fold of the final selection
        objective = tuning_objective(cfg, objective)
    space = cfg.space(objective)
    if space.dim == 0:
        raise ConfigError(cfg.source, "parameters", "every parameter is fixed: nothing to tune")
    if cfg.objective.get("timeout_s"):
        objective = TimedObjective(objective, cfg.objective["timeout_s"])
    preflight(cfg, objective, space, warn=lambda msg: print(msg, file=sys.stderr, flush=True))
    return objective, space


def new_optimizer(cfg: RunConfig, stage: int, space: Space, x0: np.ndarray | None, objective: Any = None):
    """The optimiser of a stage, seeded from ``(run seed, stage)``; bad options raise ``ConfigError``. Stage 0
    starts at ``optimizer.x0``, else at the objective's ``start_params`` when it proposes one."""
    o = cfg.optimizer
    rng = np.random.default_rng(np.random.SeedSequence([cfg.seed, stage]))
    kwargs = optimizer_options(o.population, o.generations, o.options)
    if x0 is not None:
        kwargs["x0"] = x0
    elif stage == 0 and kwargs.get("x0") is None and objective is not None:
        start = start_point(objective, space)
        if start is not None:
            kwargs["x0"] = start
    try:
        if isinstance(kwargs.get("x0"), dict):
            kwargs["x0"] = space.encode(kwargs["x0"])
        return get_optimizer(o.method)(space.dim, rng, **kwargs)
    except OptionError as exc:
        raise ConfigError(cfg.source, f"optimizer.{exc.key}" if exc.key else "optimizer",
                          f"invalid for {o.method}: {exc.message}") from None
    except (ValueError, TypeError) as exc:  # e.g. a warm start that does not fit the space, pycma refusing
        raise ConfigError(cfg.source, f"optimizer ({o.method})", str(exc)) from None


def start_point(objective: Any, space: Space) -> np.ndarray | None:
    """The objective's ``start_params`` in the unit cube of ``space`` (clipped to it; a free parameter the start
    does not name takes the objective's default), or None when it proposes none."""
    fn = hook(objective, "start_params")
    start = fn() if fn is not None else None
    if not start:
        return None
    dflt = hook(objective, "default_params")
    base = dict(dflt() or {}) if dflt is not None else {}
    values = {p.name: start.get(p.name, base.get(p.name)) for p in space.free}
    if any(v is None for v in values.values()):
        return None
    return np.clip(space.encode(values), 0.0, 1.0)


def population(cfg: RunConfig, dim: int) -> int:
    """The population the optimiser of ``cfg`` runs with on ``dim`` free parameters, with its options checked
    for that dimension (a :class:`ConfigError` naming the option): the one computation, no optimiser built."""
    o = cfg.optimizer
    options = optimizer_options(o.population, o.generations, o.options)
    check_optimizer_options(cfg.source, o.method, options, dim)
    return get_optimizer(o.method).population_for(dim, options)


def worker_count(cfg: RunConfig, space: Space) -> tuple[int, list[str]]:
    """Workers a run of ``cfg`` on ``space`` uses, and notes saying what was capped: the one rule, ``n_jobs``
    at most the :func:`population` and, for local pools, the CPU count (``serial`` takes ``n_jobs`` as is)."""
    p = cfg.parallel
    pop = population(cfg, space.dim)  # also refuses options that do not fit the dimension, before any run
    n, notes = int(p.n_jobs), []
    if p.backend == "serial":
        return n, notes
    cpus = os.cpu_count() or 1
    if n > pop:
        notes.append(f"n_jobs {n} capped at the population {pop} (more workers would idle)")
        n = pop
    if not p.address and n > cpus:
        notes.append(f"n_jobs {n} capped at the {cpus} CPUs of this machine")
        n = cpus
    return n, notes


class LiveMap:
    """``evaluate(fn, items)`` on the configured backend; the pool starts at the first live generation."""

    def __init__(self, cfg: RunConfig, n_jobs: int):
        self.cfg, self.n_jobs, self.evaluator = cfg, n_jobs, None

    def __call__(self, fn: Callable, items: list) -> list[EvalRecord]:
        if self.evaluator is None:
            p = self.cfg.parallel
            self.evaluator = Evaluator(fn, p.backend, self.n_jobs, p.address)
            self.evaluator.connect_timeout_s = p.connect_timeout_s
        return self.evaluator(items)

    def describe(self) -> str:
        p = self.cfg.parallel
        return Evaluator(None, p.backend, self.n_jobs, p.address).describe()

    def close(self) -> None:
        if self.evaluator is not None:
            self.evaluator.close()
