"""Robust against nominal tuning of controllers for uncertain plants, scored on held-out perturbed plants.

For each plant below, the same controller is tuned twice by ``tuner.run`` with the same budget, seed and
requirements: **nominal** (the nominal plant alone, what a job without ``uncertainty`` does) and
**robust** (``objective.uncertainty``: the nominal plant, its 2^k corners and 4 samples, seed 1, every
requirement on every model, the worst model's cost). Both tuned controllers are then scored on the same
**200 held-out plants** drawn from the same ranges with another seed (2), which neither tuning saw
(:func:`objectives.control.plants.robustness.assess`): the pass rate of every requirement together (the
fraction of held-out plants on which the loop meets all of them), each requirement's own pass rate, the
worst Ms and the 95th percentile of the per-plant cost. Claims hold for these plants, ranges, seeds and
budgets only; the held-out pass rate is measured on plants the tuning did not choose from.

Plants (all LTI, discretised by ZOH at the controller period; the uncertain parameters uniform):

1. **DC motor speed, PID** (configs/examples/dc_motor_robust.yaml): ``0.01 / (0.005 s^2 + 0.06 s +
   0.1001)`` rad/s per V, +-24 V; the numerator and the s^2 and s coefficients +-30 %; a 0.1 rad/s set-point
   step and a 0.5 V load step; overshoot <= 5 %, settling <= 1 s, Ms <= 1.6, phase margin >= 45 deg.
2. **First order with delay, PID** (Astrom & Hagglund's benchmark plant P4, T = 1): ``K e^{-L s} / (T s +
   1)``, K and T +-30 %, L in [0.8, 1.2] s (whole periods of 0.05 s); a unit load step at the plant input
   and a unit set-point step; Ms <= 1.4, overshoot <= 10 %.
3. **Mass on a spring-damper, LQR state feedback** (configs/examples/ss_lqr.yaml's plant): ``m x'' = -k x -
   c x' + F``, k and c +-30 % and 1/m +-20 % (entries of A and B), the gain designed on the nominal model
   with its reference pre-filter (which makes the nominal model's steady-state error 0, not a perturbed
   one's); a 1 m step; cost IAE + 0.01 effort; overshoot <= 5 %, steady-state error <= 0.02 m, peak |F| <= 20 N.

Results in ``benchmarks/results/robust_control.md``.
"""

from __future__ import annotations

import copy
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

from benchmarks.common import md_table

__all__ = ["run", "PLANTS", "job"]

_PID = {"K": {"low": 0.05, "high": 200.0, "scale": "log"}, "Ti_s": {"low": 0.05, "high": 20.0, "scale": "log"},
        "Td_s": {"low": 0.001, "high": 2.0, "scale": "log"}}

#: name -> (objective section without uncertainty, uncertain parameters, search space)
PLANTS: dict[str, tuple[dict[str, Any], dict[str, Any], dict[str, Any]]] = {
    "DC motor speed, PID": (
        {"plant": {"tf": {"num": [0.01], "den": [0.005, 0.06, 0.1001]}}, "controller": "pid2dof", "period_s": 0.002,
         "fixed": {"N": 10.0, "b": 1.0, "c": 0.0, "antiwindup": "backcalc"},
         "scenarios": [{"name": "step", "duration_s": 3.0, "reference": [{"t": 0.1, "value": 0.1}]},
                       {"name": "load", "duration_s": 2.0, "reference": [], "load": [{"t": 0.1, "value": 0.5}]}],
         "actuator": {"u_min": -24.0, "u_max": 24.0}, "cost": {"iae": 1.0},
         "requirements": {"max_overshoot_pct": 5.0, "max_settling_time_s": 1.0, "max_ms": 1.6,
                          "min_phase_margin_deg": 45.0}},
        {"tf.num[0]": {"rel": 0.3}, "tf.den[0]": {"rel": 0.3}, "tf.den[1]": {"rel": 0.3}},
        {"K": {"low": 1.0, "high": 200.0, "scale": "log"}, "Ti_s": {"low": 0.05, "high": 5.0, "scale": "log"},
         "Td_s": {"low": 0.001, "high": 0.2, "scale": "log"}}),
    "First order with delay, PID": (
        {"plant": {"tf": {"num": [1.0], "den": [1.0, 1.0]}, "delay_s": 1.0}, "controller": "pid2dof",
         "period_s": 0.05, "fixed": {"N": 10.0, "b": 1.0, "c": 0.0, "antiwindup": "none"},
         "scenarios": [{"name": "load", "duration_s": 20.0, "reference": [], "load": [{"t": 0.0, "value": 1.0}],
                        "weight": 2.0},
                       {"name": "setpoint", "duration_s": 20.0, "reference": [{"t": 0.0, "value": 1.0}]}],
         "cost": {"iae": 1.0},
         "requirements": {"max_ms": 1.4}},
        {"tf.num[0]": {"rel": 0.3}, "tf.den[0]": {"rel": 0.3}, "delay_s": [0.8, 1.2]},
        _PID),
    "Mass on a spring-damper, LQR": (
        {"plant": {"ss": {"A": [[0.0, 1.0], [-2.0, -0.5]], "B": [[0.0], [1.0]], "C": [[1.0, 0.0]], "D": [[0.0]]}},
         "controller": "lqr_sf", "period_s": 0.01,
         "scenario": {"duration_s": 6.0, "reference": [{"t": 0.2, "value": 1.0}]},
         "actuator": {"u_min": -20.0, "u_max": 20.0}, "cost": {"iae": 1.0, "effort": 0.01},
         "requirements": {"max_overshoot_pct": 5.0, "max_ss_error": 0.02, "max_peak_u": 20.0}},
        {"ss.A[1][0]": {"rel": 0.3}, "ss.A[1][1]": {"rel": 0.3}, "ss.B[1][0]": {"rel": 0.2}},
        {"q1": {"low": 0.01, "high": 1e4, "scale": "log"}, "q2": {"low": 0.01, "high": 1e3, "scale": "log"},
         "r1": {"low": 1e-4, "high": 10.0, "scale": "log"}}),
}


def job(name: str, robust: bool, pop: int, gens: int, seed: int = 1) -> dict[str, Any]:
    """The run config of plant ``name``: nominal, or with its uncertainty block (tuning set: nominal, corners,
    4 samples; 200 held-out models)."""
    section, unc, space = PLANTS[name]
    obj = {"kind": "closed_loop", **copy.deepcopy(section)}
    if robust:
        obj["uncertainty"] = {"parameters": copy.deepcopy(unc), "tune": {"corners": True, "samples": 4, "seed": 1},
                              "validate": {"samples": 200, "seed": 2}}
        obj["aggregate"] = {"scenarios": "mean", "models": "worst"}
    return {"name": "robust-bench", "seed": seed, "objective": obj, "parameters": copy.deepcopy(space),
            "optimizer": {"method": "pso", "population": pop, "generations": gens},
            "parallel": {"backend": "serial"}}


def _tune(raw: dict[str, Any]) -> tuple[dict[str, Any], float]:
    from tuner.config import config_from_dict
    from tuner.run import run as tuner_run

    with tempfile.TemporaryDirectory() as d:
        raw = {**raw, "output": d}
        cfg = config_from_dict(raw, source="benchmarks/robust_control.py", base_dir=Path(d))
        c = time.process_time()
        res = tuner_run(cfg, quiet=True, report=False)
        return dict(res.best_params), time.process_time() - c


def _heldout(name: str, params: dict[str, Any]) -> dict[str, Any]:
    """``params`` on the 200 held-out plants of ``name``: pass rates, worst Ms, cost percentile."""
    from objectives.control.objective import ClosedLoopObjective
    from objectives.control.plants.requirements import REQUIREMENTS
    from objectives.control.plants.robustness import assess
    from objectives.control.plants.tables import heldout_summary

    obj = ClosedLoopObjective.from_config(job(name, True, 1, 1)["objective"])
    a = assess(obj.loop, "tuned", params)
    h = a.heldout
    per_req = {}
    for c in h.checks:
        scen = "" if c["scenario"] is None or len(obj.loop.cases) == 1 else f" ({obj.loop.cases[c['scenario']].name})"
        per_req[f"{REQUIREMENTS[c['key']].words}{scen}"] = float(np.mean(c["met"]))
    return {**heldout_summary(h), "per_requirement": per_req, "error": h.error,
            "tuning_set_met": bool(a.tuning.pass_all().all())}


def run(smoke: bool = False, n_jobs: int = 1, **_: Any) -> dict[str, Any]:
    pop, gens = (6, 2) if smoke else (20, 25)
    names = list(PLANTS)[:1] if smoke else list(PLANTS)
    rows, results, targets_ok = [], {}, True
    for name in names:
        res = {}
        for mode in ("nominal", "robust"):
            params, cpu = _tune(job(name, mode == "robust", pop, gens))
            res[mode] = {"params": params, "tuning_cpu_s": cpu, **_heldout(name, params)}
        n, r = res["nominal"], res["robust"]
        ok = r["pass_rate"] >= 0.95 and r["pass_rate"] - n["pass_rate"] >= 0.10
        targets_ok &= ok
        results[name] = {**res, "target_met": ok}
        for mode in ("nominal", "robust"):
            x = res[mode]
            worst_req = min(x["per_requirement"].items(), key=lambda kv: kv[1]) if x["per_requirement"] else ("-", 1)
            rows.append([name, mode, ", ".join(f"{k} {v:.4g}" for k, v in x["params"].items()),
                         f"{100 * x['pass_rate']:.1f} %", f"{worst_req[0]}: {100 * worst_req[1]:.1f} %",
                         x.get("ms_max"), x.get("cost_p95"), f"{x['tuning_cpu_s']:.1f}",
                         ("met" if ok else "NOT met") if mode == "robust" else ""])
    md = [f"Each plant tuned twice (PSO, {pop} x {gens} = {pop * gens} evaluations, seed 1, serial): on the nominal "
          "plant alone, and robustly on its tuning set (nominal + 2^k corners + 4 samples, seed 1; every requirement "
          "on every model; the worst model's cost). Both tuned controllers scored on the same 200 held-out plants "
          "(seed 2, never seen by either tuning). Pass rate: the fraction of held-out plants on which every "
          "requirement holds; the lowest single requirement's pass rate beside it; Ms: the worst held-out plant's; "
          "cost p95: the 95th percentile of the per-plant cost (each plant's scenarios' weighted mean). Goal: robust "
          ">= 95 % and at least 10 points above nominal on every plant.", "",
          md_table(["plant", "tuning", "tuned", "held-out pass rate", "lowest requirement", "worst Ms", "cost p95",
                    "tuning CPU s", "goal"], rows)]
    targets = [{"target": "robust held-out pass rate >= 95 % and >= nominal + 10 points, every plant",
                "value": "; ".join(f"{k}: {100 * v['nominal']['pass_rate']:.1f} % -> "
                                   f"{100 * v['robust']['pass_rate']:.1f} %" for k, v in results.items()),
                "pass": targets_ok}]
    out = {"results": results, "markdown": "\n".join(md), "targets": targets}
    if not smoke:
        from benchmarks.common import RESULTS_DIR

        write_markdown(out, Path(RESULTS_DIR) / "robust_control.md")
    return out


def write_markdown(out: dict[str, Any], path: Path) -> Path:
    """``benchmarks/results/robust_control.md``: the module's description, the table and the goal."""
    text = "# Robust against nominal tuning on held-out uncertain plants\n\n" + \
        (__doc__ or "").split("\n\n", 1)[1] + "\n" + out["markdown"] + "\n\n" + \
        "\n".join(f"- {t['target']}: {t['value']} ({'pass' if t['pass'] else 'FAIL'})" for t in out["targets"]) + "\n"
    path.write_text(text)
    return path


if __name__ == "__main__":
    import json

    o = run()
    print(o["markdown"])
    print(json.dumps(o["targets"], indent=1))
