"""PID on Åström and Hägglund's benchmark systems: tuned by tuner against the AMIGO and SIMC rules.

Plants (K. J. Åström and T. Hägglund, "Benchmark systems for PID control", IFAC Workshop on Digital
Control: Past, Present and Future of PID Control, Terrassa, 2000), two parameter values each:

1. multiple equal poles ``1 / (s + 1)^n``, n = 3, 4;
2. fourth order ``1 / ((s + 1)(a s + 1)(a^2 s + 1)(a^3 s + 1))``, a = 0.2, 0.5;
3. right-half-plane zero ``(1 - a s) / (s + 1)^3``, a = 0.2, 1;
4. first order with delay ``e^{-s} / (T s + 1)``, T = 0.5, 5;
5. second order with delay ``e^{-s} / (T s + 1)^2``, T = 1, 5;
9. oscillatory ``w0^2 / ((s + 1)(s^2 + 2 z w0 s + w0^2))``, z = 0.1, w0 = 5, 10.

For each plant an ideal-form PID (derivative filter N = 10, the same for all) is tuned by ``tuner``
(``tuner.run`` on a ``closed_loop`` job, serial, PSO) for the IAE of a unit load-disturbance step at the
plant input, with the hard requirement Ms <= 1.4 (a candidate above it is a failed evaluation), and
compared with AMIGO (on a least-squares FOTD fit of the step response) and SIMC (half rule on the
known transfer function; on the FOTD fit for the oscillatory plant, where the half rule does not
apply): load IAE, Ms, set-point overshoot (b = 1, c = 0) and the wall and CPU time of each tuning. Goal:
tuned IAE no worse than the best rule that meets Ms <= 1.4, at Ms <= 1.4, in under 10 s per tuning.
Results in ``benchmarks/results/pid_benchmark.md``.
"""

from __future__ import annotations

import math
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

from benchmarks.common import md_table

__all__ = ["run", "PLANTS", "plant_section"]

MS_MAX = 1.4
N_FILTER = 10.0


def _poly(*factors):
    out = np.array([1.0])
    for f in factors:
        out = np.polymul(out, f)
    return out.tolist()


#: name -> (num, den, delay_s, half-rule description (k, lag time constants, delay, rhp zeros) or None)
PLANTS: dict[str, tuple[list[float], list[float], float, tuple | None]] = {
    "P1 n=3": ([1.0], _poly(*[[1, 1]] * 3), 0.0, (1.0, [1, 1, 1], 0.0, [])),
    "P1 n=4": ([1.0], _poly(*[[1, 1]] * 4), 0.0, (1.0, [1, 1, 1, 1], 0.0, [])),
    "P2 a=0.2": ([1.0], _poly([1, 1], [0.2, 1], [0.04, 1], [0.008, 1]), 0.0, (1.0, [1, 0.2, 0.04, 0.008], 0.0, [])),
    "P2 a=0.5": ([1.0], _poly([1, 1], [0.5, 1], [0.25, 1], [0.125, 1]), 0.0, (1.0, [1, 0.5, 0.25, 0.125], 0.0, [])),
    "P3 a=0.2": ([-0.2, 1.0], _poly(*[[1, 1]] * 3), 0.0, (1.0, [1, 1, 1], 0.0, [0.2])),
    "P3 a=1": ([-1.0, 1.0], _poly(*[[1, 1]] * 3), 0.0, (1.0, [1, 1, 1], 0.0, [1.0])),
    "P4 T=0.5": ([1.0], [0.5, 1.0], 1.0, (1.0, [0.5], 1.0, [])),
    "P4 T=5": ([1.0], [5.0, 1.0], 1.0, (1.0, [5.0], 1.0, [])),
    "P5 T=1": ([1.0], _poly([1, 1], [1, 1]), 1.0, (1.0, [1, 1], 1.0, [])),
    "P5 T=5": ([1.0], _poly([5, 1], [5, 1]), 1.0, (1.0, [5, 5], 1.0, [])),
    "P9 w0=5": ([25.0], _poly([1, 1], [1, 1.0, 25.0]), 0.0, None),
    "P9 w0=10": ([100.0], _poly([1, 1], [1, 2.0, 100.0]), 0.0, None),
}


def _scale(name: str) -> tuple[float, float]:
    """``(period_s, duration_s)``: the largest of 10, 20, 25, 50 ms at most Tar / 75 (Tar = sum of lags +
    delay + RHP zero; at least 10 ms, which the oscillatory plants need), and 15 Tar of simulated time.
    (Every method is scored at the same period; a delay of 1 s is then at most 50 periods.)"""
    num, den, delay, hr = PLANTS[name]
    tar = (sum(hr[1]) + hr[2] + sum(hr[3])) if hr else 1.2
    h = max([0.01] + [c for c in (0.02, 0.025, 0.05) if c <= tar / 75])
    return h, round(15 * tar, 1)


def plant_section(name: str, scenario: str = "load", fixed: dict | None = None) -> dict[str, Any]:
    """The ``objective:`` section of plant ``name``: load step IAE under Ms <= 1.4 (or a set-point step)."""
    num, den, delay, _ = PLANTS[name]
    h, dur = _scale(name)
    sc = ({"duration_s": dur, "reference": [], "load": [{"t": 0.0, "value": 1.0}]} if scenario == "load"
          else {"duration_s": dur, "reference": [{"t": 0.0, "value": 1.0}]})
    return {"kind": "closed_loop", "plant": {"tf": {"num": num, "den": den}, "delay_s": delay},
            "controller": "pid2dof", "period_s": h, "scenario": sc, "cost": {"iae": 1.0},
            "fixed": {"N": N_FILTER, "b": 1.0, "c": 0.0, "antiwindup": "none", **(fixed or {})},
            "requirements": {"max_ms": MS_MAX} if scenario == "load" else {}}


def rules(name: str) -> dict[str, tuple[float, float, float]]:
    """AMIGO and SIMC ``(K, Ti, Td)`` (ideal form) for plant ``name``."""
    import control

    from objectives.control.plants.rules import amigo_pid, fit_fotd, half_rule, series_to_ideal, simc_pid

    num, den, delay, hr = PLANTS[name]
    h, dur = _scale(name)
    t = np.arange(0, dur, h)
    y = control.step_response(control.tf(num, den), T=t).outputs.reshape(-1)
    d = int(round(delay / h))
    y = np.r_[np.zeros(d), y[: y.size - d]]
    m = fit_fotd(t, y)
    out = {"AMIGO": amigo_pid(m)}
    if hr is not None:
        k, tau1, tau2, theta = half_rule(*hr)
    else:  # complex poles: the half rule does not apply; SIMC on the fitted FOTD
        k, tau1, tau2, theta = m.K, m.T, 0.0, m.L
    out["SIMC"] = series_to_ideal(*simc_pid(k, tau1, tau2, theta))
    return out


def _score(name: str, K: float, Ti: float, Td: float) -> dict[str, float]:
    from objectives.control.objective import ClosedLoopObjective

    p = {"K": K, "Ti_s": Ti, "Td_s": Td}
    load = ClosedLoopObjective.from_config(plant_section(name))
    ev = load(p)
    if "ms" not in ev.metrics:  # diverged before it could be scored: an unstable loop
        return {"K": K, "Ti": Ti, "Td": Td, "iae": math.inf, "ms": math.inf, "overshoot_pct": math.nan}
    sp = ClosedLoopObjective.from_config(plant_section(name, "setpoint"))({**p})
    return {"K": K, "Ti": Ti, "Td": Td, "iae": ev.metrics.get("iae", math.nan), "ms": ev.metrics.get("ms", math.nan),
            "overshoot_pct": sp.metrics.get("overshoot_pct", math.nan)}


def tune(name: str, pop: int, gens: int, seed: int = 1, report: bool = True) -> tuple[dict[str, float], float, float]:
    """PID of plant ``name`` tuned by ``tuner.run``; returns its parameters, the wall and the CPU time (s)
    of the whole run (serial: one core; ``report=False``: without the run's final report)."""
    from tuner.config import config_from_dict
    from tuner.run import run as tuner_run

    h, dur = _scale(name)
    tar = dur / 15
    raw = {"name": "pid-bench", "seed": seed, "objective": plant_section(name),
           "parameters": {"K": {"low": 0.05, "high": 50.0, "scale": "log"},
                          "Ti_s": {"low": 0.02 * tar, "high": 5.0 * tar, "scale": "log"},
                          "Td_s": {"low": 0.001 * tar, "high": 1.0 * tar, "scale": "log"}},
           "optimizer": {"method": "pso", "preset": "lowbudget", "population": pop, "generations": gens},
           "parallel": {"backend": "serial"}}
    with tempfile.TemporaryDirectory() as d:
        raw["output"] = d
        cfg = config_from_dict(raw, source="benchmarks/pid_benchmark.py", base_dir=Path(d))
        t, c = time.perf_counter(), time.process_time()
        res = tuner_run(cfg, quiet=True, report=report)
        wall, cpu = time.perf_counter() - t, time.process_time() - c
    return dict(res.best_params), wall, cpu


def run(smoke: bool = False, n_jobs: int = 1, **_: Any) -> dict[str, Any]:
    pop, gens = (6, 2) if smoke else (20, 30)
    names = list(PLANTS)[:2] if smoke else list(PLANTS)
    import os

    rows, results, ok_all, cpus = [], {}, True, []
    if not smoke:  # warm-up: imports and the numba cache load are not part of one tuning
        tune(names[0], 2, 1)
    for name in names:
        scored = {rule: _score(name, *v) for rule, v in rules(name).items()}
        best, wall, cpu = tune(name, pop, gens, report=not smoke)
        cpus.append(cpu)
        scored["tuner"] = _score(name, best["K"], best["Ti_s"], best["Td_s"])
        feasible = [s["iae"] for r, s in scored.items() if r != "tuner" and s["ms"] <= MS_MAX]
        ref = min(feasible) if feasible else math.inf
        tuned = scored["tuner"]
        ok = tuned["ms"] <= MS_MAX + 1e-9 and tuned["iae"] <= ref * (1 + 1e-9) and cpu < 10.0
        ok_all &= ok
        results[name] = {**{k: v for k, v in scored.items()}, "tuning_wall_s": wall, "tuning_cpu_s": cpu,
                         "best_feasible_rule_iae": ref, "goal_met": ok}
        for r, s in scored.items():
            unstable = not math.isfinite(s["ms"])
            rows.append([name, r, f"{s['K']:.4g}", f"{s['Ti']:.4g}", f"{s['Td']:.4g}",
                         "unstable" if unstable else f"{s['iae']:.4g}", "inf" if unstable else f"{s['ms']:.3f}",
                         "" if unstable else f"{s['overshoot_pct']:.1f}",
                         f"{wall:.2f} / {cpu:.2f}" if r == "tuner" else "",
                         ("met" if ok else "NOT met") if r == "tuner" else ""])
    md = [f"PID (ideal form, N = {N_FILTER:g}) per plant: load-disturbance IAE (unit step at the plant input), "
          f"Ms, set-point overshoot (b = 1, c = 0); tuner: PSO (lowbudget preset) {pop} x {gens} = "
          f"{pop * gens} evaluations, "
          f"serial, Ms <= {MS_MAX} as a hard requirement; goal: tuned IAE <= the best rule with Ms <= {MS_MAX}, "
          "tuned Ms <= 1.4, under 10 s per tuning (the whole serial `tuner.run`: preflight, history, report; "
          "CPU time of the one core it uses, since the wall time on the shared machine depends on the other "
          f"load: load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores at the end; "
          f"OPENBLAS_NUM_THREADS={os.environ.get('OPENBLAS_NUM_THREADS', 'unset')}: on a loaded machine "
          "multi-threaded BLAS makes the small LQR/eigenvalue solves many times slower). "
          "'unstable': the rule's closed loop is unstable (Ms = inf).", "",
          md_table(["plant", "method", "K", "Ti (s)", "Td (s)", "load IAE", "Ms", "overshoot %",
                    "tuning wall / CPU s", "goal"], rows)]
    targets = [{"target": f"tuned IAE <= best rule (Ms <= {MS_MAX}) on every plant, < 10 s per tuning",
                "value": f"{sum(r['goal_met'] for r in results.values())}/{len(results)} plants; "
                         f"max CPU {max(cpus):.2f} s per tuning", "pass": ok_all}]
    out = {"results": results, "markdown": "\n".join(md), "targets": targets}
    if not smoke:
        from benchmarks.common import RESULTS_DIR

        write_markdown(out, Path(RESULTS_DIR) / "pid_benchmark.md")
    return out


def write_markdown(out: dict[str, Any], path: Path) -> Path:
    """``benchmarks/results/pid_benchmark.md``: the module's description, the table and the goal."""
    text = "# PID benchmark: tuner against AMIGO and SIMC\n\n" + (__doc__ or "").split("\n\n", 1)[1] + "\n" + \
        out["markdown"] + "\n\n" + "\n".join(f"- {t['target']}: {t['value']} ({'pass' if t['pass'] else 'FAIL'})"
                                             for t in out["targets"]) + "\n"
    path.write_text(text)
    return path


if __name__ == "__main__":
    import sys

    print(run(smoke="--smoke" in sys.argv)["markdown"])
