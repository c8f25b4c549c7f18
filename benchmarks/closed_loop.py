"""Closed-loop throughput: simulations per second of the wheeled mobile pendulum with each controller.

Each controller of the registry on the 10 s thesis profile (the objective of ``configs/wmp_*.yaml``,
eq. 2.39 cost included), one core: the median of repeated objective calls after a warm-up call
(the warm-up includes numba compilation, reported apart). Then the thesis-size tuning run, PSO with
150 particles x 150 generations of the protective fuzzy controller
(``configs/wmp_fuzzy_protective.yaml``), through ``tuner.run.run`` with 2 loky workers: wall time
and evaluations per second, history and checkpoints included.
"""

from __future__ import annotations

import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from benchmarks.common import md_table

__all__ = ["run"]

REPO = Path(__file__).resolve().parent.parent


def _objective(controller: str, duration: float):
    from objectives.control.objective import ClosedLoopObjective

    base = {"pid": "wmp_pid", "lqr": "wmp_lqr", "protective_fuzzy": "wmp_fuzzy_protective"}.get(controller)
    raw = yaml.safe_load((REPO / "configs" / f"{base or 'wmp_lqr'}.yaml").read_text())
    section = dict(raw["objective"], controller=controller, duration_s=duration)
    if base is None:  # a controller without its own config: its defaults on the LQR config's plant and cost
        section.pop("fixed", None)
    return ClosedLoopObjective.from_config(section, REPO / "configs")


def run(smoke: bool = False, n_jobs: int = 2, **_: Any) -> dict[str, Any]:
    from objectives.control.controllers import controllers_of
    from tuner.config import config_from_dict
    from tuner.run import run as tuner_run

    duration = 10.0
    reps = 1 if smoke else 30
    sims = {}
    for name in controllers_of("wmp"):  # the pendulum's (the registry also holds the generic loop's)
        try:
            obj = _objective(name, duration)
            p = obj.defaults
            t = time.perf_counter()
            ev = obj(p)
            first = time.perf_counter() - t
            times = []
            for _ in range(reps):
                t = time.perf_counter()
                obj(p)
                times.append(time.perf_counter() - t)
            med = float(np.median(times))
            sims[name] = {"sims_per_s": 1.0 / med, "seconds": med, "first_call_s": first, "status": ev.status,
                          "fitness": ev.fitness, "profile_s": duration}
        except Exception as exc:
            sims[name] = {"error": f"{type(exc).__name__}: {exc}"}
    pop, gens = (6, 1) if smoke else (150, 150)
    backend = "serial" if smoke else "loky"  # smoke: no worker start-up or per-worker compilation
    n_jobs = n_jobs if backend == "loky" else 1
    raw = yaml.safe_load((REPO / "configs" / "wmp_fuzzy_protective.yaml").read_text())
    raw["optimizer"] = {"method": "pso", "population": pop, "generations": gens}
    raw["parallel"] = {"backend": backend, "n_jobs": n_jobs}
    raw["name"] = "bench-wmp-pid-thesis-size"
    cfg = config_from_dict(raw, source="benchmarks/closed_loop.py", base_dir=REPO / "configs")
    with tempfile.TemporaryDirectory() as d:
        t = time.perf_counter()
        res = tuner_run(cfg, run_dir=Path(d) / "run", quiet=True, report=not smoke)  # smoke: no report figures
        wall = time.perf_counter() - t
    n = pop * gens
    thesis = {"population": pop, "generations": gens, "backend": backend, "n_jobs": n_jobs, "wall_s": wall,
              "evals_per_s": n / wall,
              "best_fitness": res.best_fitness, "status": res.status}
    rows = [[k, v.get("sims_per_s"), v.get("seconds"), v.get("first_call_s"), v.get("status", v.get("error", ""))]
            for k, v in sims.items()]
    md = [md_table(["controller", "sims/s (10 s profile, 1 core)", "s per sim",
                    "first call s (compile; the kernel is shared)", "status"],
                   rows),
          f"\nPSO {pop} x {gens} on the protective fuzzy problem (15 parameters, {backend}, {n_jobs} workers): "
          f"**{wall:.1f} s** wall "
          f"({n / wall:.0f} evaluations/s)."]
    return {"results": {"controllers": sims, "thesis_run": thesis},
            "markdown": "\n".join(md), "targets": []}
