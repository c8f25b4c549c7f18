"""After a run: every requirement on the tuning set, small-signal, and on the held-out models.

:func:`assess` scores one parameter set (the tuned one, the defaults) three ways and returns a typed
:class:`Assessment` that the report (:mod:`.report`) prints as one table per requirement, scenario and
model set:

- **tuning set**: the evaluation the optimiser saw (every model of the set, worst value, met on all);
- **small signal**, whenever an actuator or controller limit exists: the same scenarios (the same
  measurement noise) on the loop without actuator limits, rate limit, quanta and controller output
  limits. For LTI plants that loop is linear, so its overshoot, times and margins are those of any step small enough
  that nothing saturates, and its amplitudes (errors, |u|) scale with the step: it is run at the
  scenario's own amplitude. A stepped plant (Python dynamics, FMU) is not linear, so its small-signal
  response is the loop driven at :data:`EPSILON` of the scenario's changes about its unforced run (the
  references and loads held at their first values), the deviation scaled back by 1 / EPSILON: the loop
  linearised along the unforced trajectory. A requirement met on the tuning set but not small-signal
  is met only through saturation;
- **held-out set** (with ``uncertainty``): models drawn from another seed, never seen by the tuning:
  each requirement's pass rate, each model's pass of all, the worst margins and the distribution of
  the per-model cost.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from objectives.control.plants.metrics import _item_stats
from objectives.control.plants.requirements import REQUIREMENTS

__all__ = ["Assessment", "SetResult", "assess", "small_signal_method", "EPSILON"]

#: the fraction of a scenario's changes a stepped plant's small-signal run is driven with
EPSILON = 0.01


@dataclass
class SetResult:
    """One parameter set scored on one model set: the checks (:meth:`.loop.SISOLoop.checks`: key,
    scenario, limit, values per model, met per model), the per-model costs and margins, and the failure
    of a loop that diverged or could not be designed (then ``checks`` is empty)."""

    name: str
    n_models: int
    checks: list[dict[str, Any]] = field(default_factory=list)
    per_model: np.ndarray = field(default_factory=lambda: np.zeros(0))
    margins: list[dict[str, float]] = field(default_factory=list)
    fitness: float = math.nan
    error: str = ""

    def check(self, key: str, scenario: int | None) -> dict[str, Any] | None:
        return next((c for c in self.checks if c["key"] == key and c["scenario"] == scenario), None)

    def pass_all(self) -> np.ndarray:
        """Per model whether it meets every requirement (all False after a failure)."""
        if self.error:
            return np.zeros(self.n_models, dtype=bool)
        ok = np.ones(self.n_models, dtype=bool)
        for c in self.checks:
            ok &= c["met"]
        return ok


@dataclass
class Assessment:
    """The tuned or the default parameters on the tuning set, small-signal (or None when no limit exists)
    and on the held-out set (or None without uncertainty)."""

    label: str
    tuning: SetResult
    small: SetResult | None
    heldout: SetResult | None


def small_signal_method(loop: Any) -> str:
    """Which small-signal loop the checks use, and why (module docstring)."""
    base = "the loop without actuator limits, rate limit, quanta and controller output limits (the same noise)"
    if loop.linear:
        return (f"{base}, at the scenario's amplitude: the plant is linear, so overshoot, times and margins are those "
                "of any step small enough that nothing saturates (errors and |u| scale with the step)")
    return (f"{base}, driven at {EPSILON:g} x the scenario's changes about its unforced run and scaled back by "
            f"{1 / EPSILON:g}: the plant is not linear, so this is the loop linearised along the unforced run")


def _limited(loop: Any, cp: np.ndarray, cp_lin: np.ndarray) -> bool:
    real = loop._real
    return bool(real.limited or real.u_quantum > 0 or real.y_quantum > 0 or not np.array_equal(cp, cp_lin))


def _set_result(loop: Any, name: str, models: Any, cp: np.ndarray, stats: np.ndarray) -> SetResult:
    sc = loop.score(cp, stats, models)
    if sc.error:
        return SetResult(name, len(models), error=sc.error)
    return SetResult(name, len(models), loop.checks(sc), sc.per_model, sc.margins, sc.fitness)


def _stepped_small(loop: Any, cp: np.ndarray, models: Any) -> np.ndarray:
    """The small-signal statistics (M, S, row) of a stepped plant (module docstring)."""
    runner = loop.runner(models, linear=True)
    stats = np.zeros((len(models), len(loop.cases), runner.row))
    for s, case in enumerate(loop.cases):
        sig = runner.sigs[s]
        base = sig.copy()
        base[:, 0], base[:, 1] = sig[0, 0], sig[0, 1]
        eps = base.copy()
        eps[:, :2] += EPSILON * (sig[:, :2] - base[:, :2])
        for m in range(len(models)):
            b, e = runner.trace(cp, m, s, base), runner.trace(cp, m, s, eps)
            status = b["status"] or e["status"]
            y, u, x = (b[k] + (e[k] - b[k]) / EPSILON for k in ("y", "u", "x"))
            _item_stats(y, u, x, sig[:, 0], runner.out_idx, runner.h, case.win, sig.shape[0], float(status),
                        float(min(b["n_done"], e["n_done"])), stats[m, s])
    return stats


def assess(loop: Any, label: str, params: Mapping[str, Any], heldout: bool = True) -> Assessment:
    """``params`` on the tuning set, small-signal (when a limit exists) and on the held-out models."""
    try:
        cp, cp_lin = loop.coeffs(params), loop.linear_coeffs(params)
    except ValueError as exc:
        err = f"controller design failed: {exc}"
        return Assessment(label, SetResult("tuning", len(loop.models), error=err), None, None)
    tuning = _set_result(loop, "tuning", loop.models, cp, loop._runner.run(cp, 1)[0])
    small = None
    if _limited(loop, cp, cp_lin):
        stats = loop.runner(loop.models, linear=True).run(cp_lin, 1)[0] if loop.linear \
            else _stepped_small(loop, cp_lin, loop.models)
        small = _set_result(loop, "small signal", loop.models, cp_lin, stats)
    held = None
    hs = loop.heldout() if heldout else None
    if hs is not None:
        held = _set_result(loop, "held-out", hs, cp, loop.runner(hs).run(cp, 1)[0])
    return Assessment(label, tuning, small, held)


def saturation_only(tuned: Assessment) -> list[dict[str, Any]]:
    """The checks met on the tuning set but not small-signal: ``{key, scenario, tuned, small}`` (worst values)."""
    out = []
    if tuned.small is None or tuned.small.error or tuned.tuning.error:
        return out
    for c in tuned.tuning.checks:
        if REQUIREMENTS[c["key"]].scope == "margin" or not c["met"].all():
            continue
        s = tuned.small.check(c["key"], c["scenario"])
        if s is not None and not s["met"].all():
            out.append({"key": c["key"], "scenario": c["scenario"], "tuned": worst(c), "small": worst(s)})
    return out


def worst(check: Mapping[str, Any]) -> float:
    """The worst value of a check over its models (NaN if any is NaN)."""
    vals = np.asarray(check["values"], dtype=float)
    if vals.size == 0 or np.isnan(vals).any():
        return math.nan
    return float(vals.max() if REQUIREMENTS[check["key"]].sense == "max" else vals.min())
