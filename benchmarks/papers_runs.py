"""How ``benchmarks.papers`` measures: objectives of the paper configs, tuning runs, filter timing.

Only the public faces of the domain and the engine are used, so that the page can be regenerated
while filter kernels and closed-loop objectives move inside their packages: objectives are built by
the registry from a config's ``objective:`` section (the objectives' ``from_config``), tuning runs
go through :func:`tuner.api.tune` (the same run as ``tuner run`` with the printed command), and
filters are looked up by name (:func:`objectives.attitude.filters.get_filter`).
"""

from __future__ import annotations

import copy
import math
import resource
import shutil
import time
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import yaml

ROOT = Path(__file__).resolve().parents[1]
PAPERS = ROOT / "configs" / "papers"

__all__ = ["ROOT", "PAPERS", "config_raw", "section", "objective", "full_params", "tuned", "tune_cmd",
           "cost_per_sample", "cpu_seconds"]


def config_raw(config: str) -> dict[str, Any]:
    """The YAML mapping of ``configs/papers/<config>``."""
    return yaml.safe_load((PAPERS / config).read_text())


def section(config: str, **over: Any) -> dict[str, Any]:
    """The ``objective:`` section of ``configs/papers/<config>`` with top-level keys replaced by ``over``."""
    sec = copy.deepcopy(config_raw(config)["objective"])
    sec.update(copy.deepcopy(over))
    return sec


def objective(sec: Mapping[str, Any]) -> Any:
    """The objective of an ``objective:`` section, built by its kind's ``from_config`` through the registry
    (relative paths from ``configs/papers/``); evaluated serially in this process."""
    from tuner.registry import build_objective

    return build_objective(dict(sec), PAPERS)


def full_params(obj: Any, params: Mapping[str, Any]) -> dict[str, Any]:
    """``params`` over the objective's default (untuned) values: a complete parameter set."""
    return {**obj.default_params(), **params}


def tuned(config: str, out: Path, *, seed: int, population: int | None = None, generations: int | None = None,
          max_evals: int | None = None, sets: Sequence[str] = (), tag: str = "", light: bool = False) -> dict:
    """Tune ``config`` into ``out/<stem><tag>-s<seed>`` and return the searched values of its best point.

    The budget is PSO ``population`` x ``generations`` or, with ``max_evals``, that many evaluations of the
    config's own method; ``sets`` are ``--set`` overrides. ``light`` runs in this process instead of the
    config's workers (the same results; the smoke budget, whose few evaluations cost less than starting
    workers). No report is drawn (``tuner report RUN_DIR`` draws it later). An empty dict: no evaluation
    succeeded (e.g. none met a closed loop's requirements).
    """
    from tuner.api import tune

    run_dir = out / f"{Path(config).stem}{tag}-s{seed}"
    if run_dir.exists():  # runs/papers/ belongs to this script: each call measures afresh
        shutil.rmtree(run_dir)
    over = [f"optimizer.max_evals={max_evals}"] if max_evals is not None else [
        f"optimizer.population={population}", f"optimizer.generations={generations}"]
    res = tune(PAPERS / config, seed=seed, n_jobs=1 if light else None, run_dir=run_dir, progress=False,
               overrides=over + list(sets), report=False)
    return dict(res.params) if math.isfinite(res.fitness) else {}


def tune_cmd(config: str, budget: str, sets: Sequence[str] = ()) -> str:
    """The command line of a tuning row (``<seed>`` stands for each seed)."""
    s = "".join(f" --set '{kv}'" if " " in kv else f" --set {kv}" for kv in sets)
    return f"python -m tuner run configs/papers/{config} {budget}{s} --seed <seed>"


def cost_per_sample(filters: Mapping[str, tuple[str, Mapping[str, Any]]], rec: Any, rounds: int,
                    repeats: int = 3) -> dict[str, list[float]]:
    """Seconds per sample of each filter's ``run(rec)`` in each of ``rounds`` timing rounds.

    ``filters`` maps a label to ``(registered filter name, parameters)``. Each filter runs once first
    (its kernel compiles); in each round every filter runs ``repeats`` times in turn and keeps its fastest
    call (the least disturbed by other processes), divided by the number of samples. The call includes
    the filter's input checks and allocation, under 1 % of a long recording's time.
    """
    from objectives.attitude.filters import get_filter

    flts = {k: get_filter(name)(**dict(p)) for k, (name, p) in filters.items()}
    n = len(rec.gyr)
    for f in flts.values():
        f.run(rec)
    out: dict[str, list[float]] = {k: [] for k in flts}
    for _ in range(rounds):
        for k, f in flts.items():
            best = math.inf
            for _ in range(repeats):
                t0 = time.perf_counter()
                f.run(rec)
                best = min(best, time.perf_counter() - t0)
            out[k].append(best / n)
    return out


def cpu_seconds() -> tuple[float, float]:
    """CPU seconds (user + system) of this process and of its finished child processes.

    The reusable process pool of the tuning runs (joblib's loky executor) is shut down first, so that its
    workers' time is counted: a worker's time reaches ``RUSAGE_CHILDREN`` only once it has exited.
    """
    import sys

    pool = getattr(sys.modules.get("joblib.externals.loky.reusable_executor"), "_executor", None)
    if pool is not None:  # only a pool that exists: asking for one would start it
        pool.shutdown(wait=True)
    me = resource.getrusage(resource.RUSAGE_SELF)
    kids = resource.getrusage(resource.RUSAGE_CHILDREN)
    return me.ru_utime + me.ru_stime, kids.ru_utime + kids.ru_stime
