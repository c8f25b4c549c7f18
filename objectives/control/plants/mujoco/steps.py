"""Step metrics and requirement checks of the MuJoCo loop, on the generic loop's requirement table
(:data:`objectives.control.plants.requirements.REQUIREMENTS`: the same keys, words, units and limit checks).

The MuJoCo loop has several outputs, each with its own reference; a step metric is taken on each tracked output's
first reference step (:func:`first_step`) and a requirement holds for the worst output and, over a model set, the
worst model. It has no load input and no linear loop: load and margin requirements are errors up front.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from objectives.control.plants.requirements import REQUIREMENTS, check_limit, limit_text, requirements_from_spec

__all__ = ["STEP_METRICS", "SUPPORTED", "first_step", "step_metrics", "requirements_for", "violated"]

#: the metrics :func:`step_metrics` measures
STEP_METRICS = ("overshoot_pct", "rise_time_s", "settling_time_s", "ss_error")
#: the requirement keys a MuJoCo loop checks: the step ones and the peak control signal
SUPPORTED = tuple(k for k, r in REQUIREMENTS.items() if r.scope == "step" or k == "max_peak_u")


def first_step(r: np.ndarray) -> tuple[int, int] | None:
    """``(k0, k1)``: the first change of the reference ``r`` (a step, or a ramp's start) and the end (exclusive)
    of its window, the next change after the reference has stopped moving; None without a change."""
    ch = np.flatnonzero(np.diff(r) != 0) + 1
    if r[0] != 0:
        ch = np.r_[0, ch]
    if ch.size == 0:
        return None
    i = 0
    while i + 1 < ch.size and ch[i + 1] == ch[i] + 1:  # a ramp: consecutive changes
        i += 1
    return int(ch[0]), int(ch[i + 1]) if i + 1 < ch.size else len(r)


def step_metrics(r: np.ndarray, y: np.ndarray, h: float) -> dict[str, float]:
    """Overshoot (% of the step), 10-90 % rise time (s), 2 % settling time (s) and steady-state error at the end
    of the first reference step's window (the definitions of the generic loop's requirement table)."""
    win = first_step(r)
    nan = dict.fromkeys(STEP_METRICS, math.nan)
    if win is None:
        return nan
    k0, k1 = win
    r0 = r[k0 - 1] if k0 > 0 else 0.0
    r1 = r[k1 - 1]
    step = r1 - r0
    if step == 0:
        return nan
    yn = (y[k0:k1] - r0) / step  # normalised: 0 before, 1 at the target
    overshoot = max(0.0, float(np.max(yn)) - 1.0) * 100.0
    i10, i90 = np.flatnonzero(yn >= 0.1), np.flatnonzero(yn >= 0.9)
    rise = (i90[0] - i10[0]) * h if i10.size and i90.size else math.inf
    outside = np.flatnonzero(np.abs(yn - 1.0) > 0.02)
    settle = 0.0 if outside.size == 0 else math.inf if outside[-1] == yn.size - 1 else (outside[-1] + 1) * h
    return {"overshoot_pct": overshoot, "rise_time_s": float(rise), "settling_time_s": float(settle),
            "ss_error": float(abs(r1 - y[k1 - 1]))}


def requirements_for(spec: Any, has_step: bool, window_s: float = math.inf,
                     where: str = "objective.requirements") -> dict[str, float]:
    """The checked limits of a MuJoCo loop's ``requirements`` (the generic table's keys and limit checks; a step
    requirement needs a reference step; load and margin requirements do not apply)."""
    req = requirements_from_spec(spec, where)
    out = {}
    for k, v in req.items():
        if k not in SUPPORTED:
            raise ValueError(f"{where}.{k}: not measured on a MuJoCo plant (no load input, no linear loop); allowed: "
                             f"{list(SUPPORTED)}")
        if REQUIREMENTS[k].scope == "step" and not has_step:
            raise ValueError(f"{where}.{k}: needs a reference step in objective.scenario.reference")
        out[k] = check_limit(k, v, where, window_s)
    return out


def violated(req: Mapping[str, float], m: Mapping[str, float]) -> str:
    """The first violated requirement in words ('' when all are met); a NaN metric counts as violated."""
    for key, lim in req.items():
        r = REQUIREMENTS[key]
        v = m.get(r.metric, math.nan)
        ok = v <= lim if r.sense == "max" else v >= lim
        if not ok:
            return f"{r.words} {v:.4g}, required {limit_text(key, lim)} ({key})"
    return ""
