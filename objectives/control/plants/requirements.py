"""Requirements of the generic loop: what each one measures, where, in which unit, and how it is checked.

YAML (``objective:``)::

    requirements: {max_overshoot_pct: 5, max_settling_time_s: 2, max_ms: 1.6, min_phase_margin_deg: 45}
    scenarios:
      - {name: small, duration_s: 3, reference: [{t: 0.1, value: 0.1}], requirements: {max_overshoot_pct: 5}}

A requirement under ``objective.requirements`` holds in every scenario where its quantity is defined
(a step metric in every scenario with a reference step, a load metric in every scenario with a load
step; at least one scenario must define it) and on every model of the tuning set; one under a
scenario's own ``requirements`` holds in that scenario. Margin requirements (Ms, gain and phase margin)
are properties of the linear loop, not of a scenario: they are given under ``objective.requirements``
only and hold on every model. A candidate that violates any of them is a failed evaluation whose error
names every violated requirement, each with its worst value, scenario and model, separated by ``"; "``.

Limits no loop can meet (an overshoot below 0 %, Ms below 1, a phase margin of 180 deg or more, a time
limit longer than the window it is measured in) are errors up front. ``max_ss_error: 0`` means "below
:data:`SS_TOLERANCE` times the step" (an error that only tends to 0 is never exactly 0 on a finite
run); the requirements table prints the tolerance as the limit.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

__all__ = ["Requirement", "REQUIREMENTS", "SS_TOLERANCE", "METRIC_WORDS", "metric_words", "check_limit",
           "requirements_from_spec", "violation", "limit_text"]

#: ``max_ss_error: 0`` means |error| <= SS_TOLERANCE x |step| (0.1 % of the step) at the end of its window
SS_TOLERANCE = 1e-3


@dataclass(frozen=True)
class Requirement:
    """One requirement key.

    Attributes
    ----------
    key : str
        The YAML key (``max_overshoot_pct``).
    metric : str
        The metric it bounds (``overshoot_pct``), a key of every evaluation's metrics.
    sense : {"max", "min"}
        ``max``: the metric must be <= the limit; ``min``: >= the limit.
    words, unit : str
        What the metric is in words, and its unit ("output" and "input" are the plant's own units).
    where : str
        Where and how it is measured (``tuner describe requirements`` prints it).
    scope : {"step", "load", "signal", "margin"}
        Which scenarios define it: those with a reference step, with a load step, every one, or none
        (a property of the linear loop on each model).
    lowest : float
        The smallest limit any loop could meet; ``strict``: the limit must be above it.
    why : str
        Why a limit below ``lowest`` cannot be met.
    """

    key: str
    metric: str
    sense: str
    words: str
    unit: str
    where: str
    scope: str
    lowest: float = -math.inf
    strict: bool = False
    why: str = ""


_STEP_WHERE = "the first reference step of the scenario (a step, or a ramp's start), up to the next change of the " \
              "reference or the load, or the end"
REQUIREMENTS: dict[str, Requirement] = {r.key: r for r in (
    Requirement("max_overshoot_pct", "overshoot_pct", "max", "overshoot", "%",
                f"largest excursion of the output past the new set point, in % of the step; on {_STEP_WHERE}",
                "step", 0.0, False, "overshoot is >= 0 %"),
    Requirement("max_rise_time_s", "rise_time_s", "max", "10-90 % rise time", "s",
                f"time from 10 % to 90 % of the step; on {_STEP_WHERE}", "step", 0.0, True,
                "a time limit must be > 0 s"),
    Requirement("max_settling_time_s", "settling_time_s", "max", "2 % settling time", "s",
                f"time after the step from which the output stays within 2 % of the step; on {_STEP_WHERE}",
                "step", 0.0, True, "a time limit must be > 0 s"),
    Requirement("max_ss_error", "ss_error", "max", "steady-state error", "output",
                f"|set point - output| at the end of the window of {_STEP_WHERE}; a limit of 0 means "
                f"<= {SS_TOLERANCE:g} x |step|", "step", 0.0, False, "the error is an absolute value"),
    Requirement("max_load_peak_error", "load_peak_error", "max", "peak error after a load step", "output",
                "largest |set point - output| from the first load step to the next change of the load or the "
                "reference, or the end", "load", 0.0, True, "a peak error of 0 allows no load response"),
    Requirement("max_peak_u", "peak_u", "max", "peak control signal |u|", "input",
                "largest |u| of the actuator's output (before the load) over the whole scenario", "signal", 0.0,
                True, "peak |u| is >= 0 and 0 allows no control"),
    Requirement("max_u_std", "u_std", "max", "control-signal standard deviation", "input",
                "standard deviation of u (input 0) over the whole scenario: in a scenario of measurement noise "
                "alone, the control activity the noise causes", "signal", 0.0, True,
                "a standard deviation of 0 allows no control action"),
    Requirement("min_gain_margin_db", "gm_db", "min", "gain margin", "dB",
                "-20 log10 |L| where the phase of the loop L = C P (broken at plant input 0) crosses -180 deg; "
                "LTI plants, every model", "margin"),
    Requirement("min_phase_margin_deg", "pm_deg", "min", "phase margin", "deg",
                "180 deg + arg L at the gain crossover |L| = 1 (the smallest); LTI plants, every model",
                "margin"),
    Requirement("max_ms", "ms", "max", "maximum sensitivity Ms", "1",
                "max over frequency of |1 / (1 + L)| (1 / Ms is the distance of L from -1); LTI plants, every "
                "model; inf for an unstable closed loop", "margin", 1.0, False,
                "Ms = max |S| is >= 1 for a strictly proper loop; 1.2-2.0 is usual"),
)}

#: every metric of an evaluation in words with its unit (reports, tables, ``tuner describe``)
METRIC_WORDS: dict[str, tuple[str, str]] = {
    **{r.metric: (r.words, r.unit) for r in REQUIREMENTS.values()},
    "cl_pole_max": ("largest closed-loop pole magnitude |z| (stable below 1)", "1"),
    "iae": ("integral of |error|", "output s"),
    "ise": ("integral of error^2", "output^2 s"),
    "itae": ("integral of t |error|", "output s^2"),
    "itse": ("integral of t error^2", "output^2 s^2"),
    "effort": ("integral of u^2", "input^2 s"),
    "tv": ("total variation of u", "input"),
    "cost": ("cost", "1"),
    "status_code": ("loop status (0 ok, 2 diverged, 3 wrong shape)", "1"),
}


def metric_words(key: str) -> str:
    """``"overshoot (%)"`` for ``overshoot_pct``; a scenario prefix (``small.overshoot_pct``) is kept in front."""
    scen, _, base = key.rpartition(".")
    words = METRIC_WORDS.get(base)
    if words is None:
        return key
    text = f"{words[0]} ({words[1]})" if words[1] != "1" else words[0]
    return f"{scen}: {text}" if scen else text


def check_limit(key: str, value: Any, where: str, window_s: float = math.inf) -> float:
    """A validated limit of requirement ``key`` (``where``: the YAML path for the message); ``window_s``:
    the shortest window the requirement is measured in (a longer time limit could never be checked)."""
    r = REQUIREMENTS[key]
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise ValueError(f"{where}.{key}: must be a finite number, got {value!r}")
    v = float(value)
    if v < r.lowest or (r.strict and v == r.lowest):
        raise ValueError(f"{where}.{key}: {v:g} cannot be met; must be {'>' if r.strict else '>='} {r.lowest:g} "
                         f"({r.why})")
    if key == "min_phase_margin_deg" and v >= 180.0:
        raise ValueError(f"{where}.{key}: {v:g} cannot be met; a phase margin is below 180 deg (30-60 is usual)")
    if key in ("max_rise_time_s", "max_settling_time_s") and v > window_s:
        raise ValueError(f"{where}.{key}: {v:g} s is longer than the first step's window ({window_s:g} s) in which it "
                         "is measured; raise the scenario's duration_s or lower the limit")
    return v


def requirements_from_spec(spec: Any, where: str) -> dict[str, Any]:
    """The keys of a ``requirements`` mapping, each known (``ValueError`` naming the key and listing the
    allowed ones otherwise); the limits are checked per scenario by :func:`check_limit`."""
    if spec is None:
        return {}
    if not isinstance(spec, Mapping):
        raise ValueError(f"{where}: expected a mapping of requirement: limit, got {spec!r}")
    for k in spec:
        if k not in REQUIREMENTS:
            import difflib

            close = difflib.get_close_matches(str(k), list(REQUIREMENTS), n=1)
            hint = f" (did you mean {close[0]}?)" if close else ""
            raise ValueError(f"{where}.{k}: unknown requirement{hint}; allowed: {sorted(REQUIREMENTS)} "
                             "(tuner describe requirements)")
    return dict(spec)


def violation(key: str, value: float, limit: float) -> float:
    """How far ``value`` is past ``limit`` relative to the limit's scale (0 when met, at most 10; NaN 10)."""
    r = REQUIREMENTS[key]
    if math.isnan(value):
        return 10.0
    over = value - limit if r.sense == "max" else limit - value
    if over <= 0:
        return 0.0
    return min(10.0, over / max(abs(limit), 1e-9 if r.sense == "max" else 1.0))


def limit_text(key: str, limit: float) -> str:
    """``"<= 5 %"``: a limit with its sense and unit."""
    r = REQUIREMENTS[key]
    unit = "" if r.unit == "1" else f" {r.unit}"
    return f"{'<=' if r.sense == 'max' else '>='} {limit:g}{unit}"
