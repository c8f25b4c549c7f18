"""``init:``: the PID a generic-loop job starts from, by a tuning rule on a stated model fit of the plant.

YAML (``objective:``)::

    init: amigo                 # or simc; the same as {rule: amigo}
    init: {rule: simc, fit: lsq, max_ms: 1.4}

- ``rule``: ``amigo`` or ``simc`` (:mod:`.rules`); SIMC on a FOTD model (``tau2 = 0``) is a PI;
- ``fit``: the FOTD fit of the plant's unit step response, ``area`` (the method of areas, the default) or
  ``lsq`` (least squares); the response is the plant's own (its delay, its sampling at the controller
  period, no controller), long enough to settle (:func:`step_response`);
- ``max_ms``: the rule is detuned along its own knob until the sampled loop's Ms meets this limit
  (:func:`~.rules.detune_to_ms`); default: the job's ``requirements.max_ms`` when it has one, else none.

The start becomes the controller's defaults (the report's "defaults" column: the rule's PID) and the point
the search starts from (the objective's ``start_params`` hook). Values under ``fixed`` win over the rule's.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from objectives.control.kinds import KIND_OPEN
from objectives.control.plants.rules import (
    FITS,
    FOTD,
    amigo_detuned,
    detune_to_ms,
    fit_fotd,
    simc_detuned,
)
from objectives.control.plants.scenario import Realism
from objectives.control.plants.simulate import simulate_loop

__all__ = ["RULES", "Start", "init_from_spec", "step_response", "rule_start"]

RULES = ("amigo", "simc")
#: samples of the step response at most (a slow plant at a short period is cut here, and must have settled)
MAX_STEP_SAMPLES = 200_000


def init_from_spec(spec: Any, ms_requirement: float | None) -> dict[str, Any] | None:
    """The validated ``init`` block (``None`` for none); ``ValueError`` naming the key otherwise."""
    if spec is None:
        return None
    if isinstance(spec, str):
        spec = {"rule": spec}
    if not isinstance(spec, Mapping):
        raise ValueError(f"objective.init: a rule name ({' | '.join(RULES)}) or {{rule, fit, max_ms}}, got {spec!r}")
    unknown = sorted(set(spec) - {"rule", "fit", "max_ms"})
    if unknown:
        raise ValueError(f"objective.init.{unknown[0]}: unknown key; allowed: rule, fit, max_ms")
    rule, fit = spec.get("rule"), spec.get("fit", "area")
    if rule not in RULES:
        raise ValueError(f"objective.init.rule: one of {list(RULES)}, got {rule!r}")
    if fit not in FITS:
        raise ValueError(f"objective.init.fit: one of {list(FITS)} (least squares, method of areas), got {fit!r}")
    ms = spec.get("max_ms", ms_requirement)
    if ms is not None and (isinstance(ms, bool) or not isinstance(ms, (int, float)) or not ms >= 1.0):
        raise ValueError(f"objective.init.max_ms: a number >= 1 (Ms of a loop is >= 1), got {ms!r}")
    return {"rule": rule, "fit": fit, "max_ms": None if ms is None else float(ms)}


def step_response(plant: Any, duration_s: float) -> tuple[np.ndarray, np.ndarray]:
    """The plant's unit step response ``(t, y)`` of its controlled output at the controller period: the
    generic loop kernel with no controller (a step of input 0 at t = 0), over ``duration_s``, or for a plant
    with a linear model (``design_model``) long enough for its slowest mode to fall to ``e^-12``.
    ``ValueError`` if the response has not settled (its last tenth moves by more than 1 % of its end value)."""
    h = plant.period_s
    try:
        a, _ = plant.design_model()
        lam = np.abs(np.linalg.eigvals(np.asarray(a, dtype=float))) if np.size(a) else np.zeros(0)
    except ValueError:
        lam = None
    if lam is not None:
        if np.any(lam >= 1.0):
            raise ValueError("objective.init: the rules need a self-regulating plant (its linear model has a pole "
                             "on or outside the unit circle)")
        slow = max((-h / math.log(x) for x in lam if x > 0), default=h)
        duration_s = max(duration_s, 12.0 * slow + plant.delay_n * h)
    n = int(min(MAX_STEP_SAMPLES, max(50, math.ceil(duration_s / h))))
    n_meas = plant.n_outputs
    sig = np.zeros((n, 2 + n_meas))
    sig[:, 0] = 1.0
    sim = simulate_loop(plant, KIND_OPEN, np.zeros(1), np.ascontiguousarray(sig), Realism())
    if sim["status"] != 0:
        raise ValueError("objective.init: the plant's open-loop step response diverged")
    y = sim["y"][:, plant.output]
    tail = y[int(0.9 * n):]
    if not (np.ptp(tail) <= 0.01 * abs(y[-1]) and abs(y[-1]) > 0):
        raise ValueError(f"objective.init: the plant's step response has not settled within {n * h:g} s (or "
                         "its gain is zero); the rules need a self-regulating plant")
    return sim["t"], y


@dataclass(frozen=True)
class Start:
    """A rule's PID on a fitted model: ``rule``, ``fit``, the FOTD ``model``, ``pid`` ``(K, Ti, Td)`` in ideal
    form, the ``knob`` it was detuned to (1: the rule as published), its ``ms`` (NaN when not detuned to a
    limit) and ``max_ms``."""

    rule: str
    fit: str
    model: FOTD
    pid: tuple[float, float, float]
    knob: float
    ms: float
    max_ms: float | None

    def describe(self) -> str:
        m = self.model
        what = {"amigo": "AMIGO", "simc": "SIMC (tau_c = theta)"}[self.rule]
        fit = {"lsq": "least-squares", "area": "method-of-areas"}[self.fit]
        if self.max_ms is None:
            knob = ""
        elif self.knob == 1.0:
            knob = f", Ms {self.ms:.4g} <= {self.max_ms:g} as published"
        else:
            name = "gain factor" if self.rule == "amigo" else "tau_c / theta"
            knob = f", detuned to Ms {self.ms:.4g} <= {self.max_ms:g} ({name} {self.knob:.4g})"
        return (f"{what} on the {fit} FOTD fit K = {m.K:.4g}, T = {m.T:.4g} s, L = {m.L:.4g} s of the plant's "
                f"step response{knob}")


def rule_family(rule: str, model: FOTD) -> tuple[Callable[[float], tuple[float, float, float]], str]:
    """``(family, toward)``: the rule's PID as a function of its knob, and the knob's robust direction."""
    if rule == "amigo":
        return (lambda a: amigo_detuned(model, a)), "down"
    sopdt = (model.K, model.T, 0.0, model.L)
    return (lambda lam: simc_detuned(sopdt, lam)), "up"


def rule_start(plant: Any, spec: Mapping[str, Any], ms_of: Callable[[tuple[float, float, float]], float],
               duration_s: float) -> Start:
    """The start of ``spec`` (:func:`init_from_spec`) on ``plant``; ``ms_of(pid)`` is the sampled loop's Ms."""
    t, y = step_response(plant, duration_s)
    model = fit_fotd(t, y, spec["fit"])
    family, toward = rule_family(spec["rule"], model)
    if spec["max_ms"] is None:
        pid = family(1.0)
        return Start(spec["rule"], spec["fit"], model, pid, 1.0, math.nan, None)
    d = detune_to_ms(family, ms_of, spec["max_ms"], toward)
    return Start(spec["rule"], spec["fit"], model, d.pid, d.knob, d.ms, spec["max_ms"])
