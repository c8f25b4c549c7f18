"""The robust part of the PID benchmark: on each of Åström and Hägglund's benchmark plants with its gain, time
constants and delay uncertain by +-30 %, a PID tuned on the nominal plant against one tuned on a model set,
both scored on 200 held-out perturbed plants.

The problem is :mod:`benchmarks.pid_plants`'s (the sampled loop, load-step IAE) with the robustness limit
Ms <= :data:`MS_LIMIT`. The plants are written as zeros, poles and gain (``zpk``) so that each time constant is
one parameter: every real pole ``-1/T`` is drawn with ``T`` in ``[0.7 T, 1.3 T]`` (uniform in ``-1/T``), a
right-half-plane zero's time constant likewise, the gain factor ``k`` in ``k (1 -+ 0.3)`` and the delay in
``[0.7 L, 1.3 L]`` (on the controller's sampling grid). The oscillatory plants (P9) have a complex pole pair,
which a ``zpk`` list of real numbers cannot hold: they are the transfer function with the gain uncertain only.

For each plant the PID is tuned twice by ``tuner.run`` with the same budget and seed: **nominal** (Ms <= 1.6 on
the nominal plant) and **robust** (``objective.uncertainty``: the nominal plant and :data:`TUNE_SAMPLES` drawn
models, seed 1, Ms <= 1.6 on every one, the worst model's IAE). Both are scored on the same 200 held-out plants
(seed 2) that neither tuning saw (:func:`objectives.control.plants.robustness.assess`): the pass rate of Ms <=
1.6 and the 95th percentile of the IAE. Results in ``benchmarks/results/pid_benchmark.md`` (robust part).
"""

from __future__ import annotations

import copy
import math
import tempfile
import time
from pathlib import Path
from typing import Any

from benchmarks.common import md_table
from benchmarks.pid_plants import PLANTS, box, plant_section

__all__ = ["run", "zpk_plant", "job", "MS_LIMIT", "TUNE_SAMPLES", "REL"]

MS_LIMIT = 1.6
REL = 0.3
TUNE_SAMPLES = 16
POP, GENS = 20, 40


def zpk_plant(name: str) -> tuple[dict[str, Any], dict[str, Any]]:
    """``(plant spec, uncertain parameters)`` of plant ``name`` (module docstring)."""
    num, den, delay, hr = PLANTS[name]
    if hr is None:  # complex poles: the transfer function, its gain uncertain
        return {"tf": {"num": num, "den": den}, "delay_s": delay}, {"tf.num[0]": {"rel": REL}}
    k0, taus, theta, rhp = hr
    poles = [-1.0 / t for t in taus]
    zeros = [1.0 / a for a in rhp]
    # k prod(s - z) / prod(s - p) with unit DC gain: (1 - a s) = -a (s - 1/a), (T s + 1) = T (s + 1/T)
    k = k0 * math.prod(-a for a in rhp) / math.prod(taus)
    spec = {"zpk": {"z": zeros, "p": poles, "k": k}, "delay_s": theta}
    unc: dict[str, Any] = {"zpk.k": {"rel": REL}}
    for i, t in enumerate(taus):
        unc[f"zpk.p[{i}]"] = sorted([-1.0 / ((1 - REL) * t), -1.0 / ((1 + REL) * t)])
    for i, a in enumerate(rhp):
        unc[f"zpk.z[{i}]"] = sorted([1.0 / ((1 + REL) * a), 1.0 / ((1 - REL) * a)])
    if theta > 0:
        unc["delay_s"] = [(1 - REL) * theta, (1 + REL) * theta]
    return spec, unc


def job(name: str, robust: bool, seed: int = 1, pop: int = POP, gens: int = GENS) -> dict[str, Any]:
    """The run config of plant ``name``: nominal, or tuned on the model set (the held-out set: 200, seed 2)."""
    spec, unc = zpk_plant(name)
    obj = plant_section(name, ms_max=MS_LIMIT, plant=copy.deepcopy(spec))
    if robust:
        obj["uncertainty"] = {"parameters": unc, "tune": {"corners": False, "samples": TUNE_SAMPLES, "seed": 1},
                              "validate": {"samples": 200, "seed": 2}}
        obj["aggregate"] = {"models": "worst"}
    return {"name": "pid-robust", "seed": seed, "objective": obj,
            "parameters": {k: {"low": lo, "high": hi, "scale": "log"} for k, (lo, hi) in box(name).items()},
            "optimizer": {"method": "pso", "population": pop, "generations": gens},
            "parallel": {"backend": "serial"}}


def _tune(raw: dict[str, Any]) -> tuple[dict[str, float], float, Any]:
    from tuner.config import config_from_dict
    from tuner.run import run as tuner_run

    with tempfile.TemporaryDirectory() as d:
        raw = {**raw, "output": d}
        cfg = config_from_dict(raw, source="benchmarks/pid_robust.py", base_dir=Path(d))
        c = time.process_time()
        res = tuner_run(cfg, quiet=True, report=False)
        return dict(res.best_params), time.process_time() - c, cfg


def heldout(name: str, params: dict[str, float]) -> dict[str, float]:
    """``params`` on the 200 held-out plants: the pass rate of Ms <= 1.6, the worst Ms and the IAE's 95th
    percentile."""
    from objectives.control.objective import ClosedLoopObjective
    from objectives.control.plants.robustness import assess
    from objectives.control.plants.tables import heldout_summary

    obj = ClosedLoopObjective.from_config(job(name, True)["objective"])
    a = assess(obj.loop, "tuned", params)
    s = heldout_summary(a.heldout)
    return {"pass_rate": s["pass_rate"], "ms_max": s.get("ms_max", math.inf), "iae_p95": s.get("cost_p95", math.inf),
            "error": a.heldout.error}


def run(smoke: bool = False, **_: Any) -> dict[str, Any]:
    pop, gens = (6, 2) if smoke else (POP, GENS)
    names = list(PLANTS)[:1] if smoke else list(PLANTS)
    results, rows = {}, []
    for name in names:
        res = {}
        for mode in ("nominal", "robust"):
            params, cpu, _ = _tune(job(name, mode == "robust", 1, pop, gens))
            res[mode] = {"params": params, "tuning_cpu_s": cpu, **heldout(name, params)}
        results[name] = res
        n, r = res["nominal"], res["robust"]
        rows.append([name, f"{100 * n['pass_rate']:.1f} %", f"{100 * r['pass_rate']:.1f} %", f"{n['ms_max']:.3f}",
                     f"{r['ms_max']:.3f}", f"{n['iae_p95']:.4g}", f"{r['iae_p95']:.4g}",
                     f"{n['tuning_cpu_s']:.1f} / {r['tuning_cpu_s']:.1f}"])
    md = [f"Robust part: each plant with its gain, time constants and delay uncertain by +-{100 * REL:.0f} % (the "
          "oscillatory plants: the gain only), the PID tuned on the nominal plant and on the nominal plant and "
          f"{TUNE_SAMPLES} drawn models (seed 1; Ms <= {MS_LIMIT} on every one, the worst model's IAE); PSO "
          f"{pop} x {gens} = {pop * gens} evaluations each, serial, seed 1. Both scored on the same 200 held-out "
          f"plants (seed 2): the pass rate of Ms <= {MS_LIMIT}, the worst Ms and the 95th percentile of the load "
          "IAE.", "",
          md_table(["plant", "Ms pass rate, nominal", "robust", "worst Ms, nominal", "robust", "IAE p95, nominal",
                    "robust", "tuning CPU s (nominal / robust)"], rows)]
    return {"results": results, "markdown": "\n".join(md)}


if __name__ == "__main__":
    print(run()["markdown"])
