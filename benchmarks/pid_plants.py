"""The PID benchmark's problem: Åström and Hägglund's benchmark plants and the one tuning problem on each.

Plants (K. J. Åström and T. Hägglund, "Benchmark systems for PID control", IFAC Workshop on Digital
Control: Past, Present and Future of PID Control, Terrassa, 2000), two parameter values each:

1. multiple equal poles ``1 / (s + 1)^n``, n = 3, 4;
2. fourth order ``1 / ((s + 1)(a s + 1)(a^2 s + 1)(a^3 s + 1))``, a = 0.2, 0.5;
3. right-half-plane zero ``(1 - a s) / (s + 1)^3``, a = 0.2, 1;
4. first order with delay ``e^{-s} / (T s + 1)``, T = 0.5, 5;
5. second order with delay ``e^{-s} / (T s + 1)^2``, T = 1, 5;
9. oscillatory ``w0^2 / ((s + 1)(s^2 + 2 z w0 s + w0^2))``, z = 0.1, w0 = 5, 10.

The problem on each (the same for the tuner, the rules and the independent optimum): an ideal-form PID
``K (b r - y) + K / Ti int e + K Td d/dt (c r - y)`` with derivative filter ``Td / N``, N = 10, b = 1,
c = 0 and no anti-windup (nothing saturates), run by the sampled loop at the period of :func:`scale` (ZOH
plant, forward-Euler integral, backward-difference derivative: :mod:`objectives.control.plants.controllers`);
cost: the IAE of a unit load step at the plant input from t = 0 over 15 ``Tar``; constraint: the sampled
loop's ``Ms <= MS_MAX``; search box :func:`box` (log scale in each parameter).
"""

from __future__ import annotations

from typing import Any

import numpy as np

__all__ = ["PLANTS", "MS_MAX", "N_FILTER", "scale", "tar", "box", "plant_section", "continuous"]

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


def continuous(name: str) -> tuple[list[float], list[float], float]:
    """``(num, den, delay_s)`` of plant ``name``."""
    num, den, delay, _ = PLANTS[name]
    return num, den, delay


def tar(name: str) -> float:
    """The average residence time ``Tar`` (s): sum of lags + delay + RHP zero (1.2 s for the oscillatory
    plants, whose half rule does not apply)."""
    hr = PLANTS[name][3]
    return (sum(hr[1]) + hr[2] + sum(hr[3])) if hr else 1.2


def scale(name: str) -> tuple[float, float]:
    """``(period_s, duration_s)``: the largest of 10, 20, 25, 50 ms at most Tar / 75 (at least 10 ms, which
    the oscillatory plants need), and 15 Tar of simulated time. (Every method is scored at the same
    period; a delay of 1 s is then at most 50 periods.)"""
    t = tar(name)
    h = max([0.01] + [c for c in (0.02, 0.025, 0.05) if c <= t / 75])
    return h, round(15 * t, 1)


def box(name: str) -> dict[str, tuple[float, float]]:
    """The search box (every method's): K in [0.05, 50], Ti in [0.02, 5] Tar, Td in [0.001, 1] Tar."""
    t = tar(name)
    return {"K": (0.05, 50.0), "Ti_s": (0.02 * t, 5.0 * t), "Td_s": (0.001 * t, 1.0 * t)}


def plant_section(name: str, scenario: str = "load", ms_max: float | None = MS_MAX, plant: dict | None = None,
                  fixed: dict | None = None) -> dict[str, Any]:
    """The ``objective:`` section of plant ``name`` (or of ``plant``, a perturbed copy): load-step IAE under
    ``Ms <= ms_max`` (None: no requirement), or a set-point step (``scenario="setpoint"``)."""
    num, den, delay = continuous(name)
    h, dur = scale(name)
    sc = ({"duration_s": dur, "reference": [], "load": [{"t": 0.0, "value": 1.0}]} if scenario == "load"
          else {"duration_s": dur, "reference": [{"t": 0.0, "value": 1.0}]})
    req = {"max_ms": ms_max} if scenario == "load" and ms_max is not None else {}
    return {"kind": "closed_loop", "plant": plant or {"tf": {"num": num, "den": den}, "delay_s": delay},
            "controller": "pid2dof", "period_s": h, "scenario": sc, "cost": {"iae": 1.0},
            "fixed": {"N": N_FILTER, "b": 1.0, "c": 0.0, "antiwindup": "none", **(fixed or {})},
            "requirements": req}
