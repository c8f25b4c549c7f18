"""The generic loop's cost: terms of one response, and their aggregation over scenarios and models.

YAML (``objective:``)::

    cost: {iae: 1.0, effort: 0.01}          # weighted sum of terms (TERMS), or
    cost: {mae_product: {e: 1.4, u: 0.4}}   # thesis eq. 2.39 generalised: prod mean(|s|)^w
    aggregate: {scenarios: mean, models: worst}   # or one form for both: aggregate: {cvar: 0.2}

Terms of one response (e = r - y of the controlled output, t from the scenario's start, h the period):
IAE = sum |e| h, ISE = sum e^2 h, ITAE = sum t |e| h, ITSE = sum t e^2 h, ``effort`` = sum u^2 h,
``tv`` = sum |u[k] - u[k-1]| (total variation); ``mae_product`` signals: ``e``, ``u``, ``du`` (u rate,
1/s), ``y<i>`` (output i), ``x<i>`` (state i). Every term is computed by the loop's statistics kernel
(:mod:`.metrics`); a scenario may give its own ``cost``.

Aggregation. Each (scenario, model) pair has the cost of its response, ``c[m, s]``. The scenarios of one
model are aggregated first, with the scenarios' weights (``w_s`` normalised to sum 1), then the models
(equal weights) (:func:`objectives.attitude.aggregate.aggregate`, the same functions the filters use):

- ``mean``: the weighted mean ``sum_s w_s c[m, s]`` (the default);
- ``worst``: the largest cost among the items of non-zero weight;
- ``{cvar: alpha}``: the conditional value at risk, the weighted mean of the worst items that together
  carry weight ``alpha`` in (0, 1] (Rockafellar & Uryasev 2002; ``alpha = 1`` is the mean).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from objectives.attitude.aggregate import aggregate

__all__ = ["TERMS", "cost_from_spec", "Aggregation", "aggregation_from_spec", "cost_of_stats", "combine"]

TERMS = ("iae", "ise", "itae", "itse", "effort", "tv")


def _weight(key: str, v: Any) -> float:
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or v < 0:
        raise ValueError(f"{key}: must be a finite number >= 0, got {v!r}")
    return float(v)


def cost_from_spec(spec: Any, key: str = "objective.cost") -> dict[str, Any]:
    """Validated ``cost`` (default ``{iae: 1}``)."""
    if spec is not None and not isinstance(spec, Mapping):
        raise ValueError(f"{key}: expected a mapping of term: weight, got {spec!r}")
    spec = dict(spec or {"iae": 1.0})
    if "mae_product" in spec:
        if len(spec) != 1 or not isinstance(spec["mae_product"], Mapping) or not spec["mae_product"]:
            raise ValueError(f"{key}.mae_product: give it alone, as {{signal: exponent}}")
        for s, w in spec["mae_product"].items():
            ok = s in ("e", "u", "du") or (isinstance(s, str) and s[:1] in "xy" and s[1:].isdigit())
            if not ok:
                raise ValueError(f"{key}.mae_product.{s}: unknown signal; allowed: e, u, du, y<i>, x<i>")
            _weight(f"{key}.mae_product.{s}", w)
        return {"mae_product": dict(spec["mae_product"])}
    for k, w in spec.items():
        if k not in TERMS:
            raise ValueError(f"{key}.{k}: unknown term; allowed: {list(TERMS)} or mae_product "
                             "(tuner describe cost)")
        _weight(f"{key}.{k}", w)
    return spec


@dataclass(frozen=True)
class Aggregation:
    """How costs are combined over scenarios and over models: ``mean``, ``worst`` or ``cvar`` (with ``alpha``)."""

    scenarios: str = "mean"
    scenarios_alpha: float = 1.0
    models: str = "mean"
    models_alpha: float = 1.0

    def text(self) -> str:
        def one(m: str, a: float) -> str:
            return f"CVaR {a:g}" if m == "cvar" else ("weighted mean" if m == "mean" else "worst case")
        return f"scenarios: {one(self.scenarios, self.scenarios_alpha)}, models: {one(self.models, self.models_alpha)}"


def _form(key: str, v: Any) -> tuple[str, float]:
    if v in ("mean", "worst"):
        return str(v), 1.0
    if isinstance(v, Mapping) and set(v) == {"cvar"}:
        a = v["cvar"]
        if isinstance(a, bool) or not isinstance(a, (int, float)) or not 0.0 < a <= 1.0:
            raise ValueError(f"{key}.cvar: the tail mass alpha must be in (0, 1], got {a!r}")
        return "cvar", float(a)
    raise ValueError(f"{key}: mean, worst or {{cvar: alpha}} (0 < alpha <= 1), got {v!r}")


def aggregation_from_spec(spec: Any, key: str = "objective.aggregate") -> Aggregation:
    """``aggregate``: one form for both levels, or ``{scenarios: form, models: form}`` (each defaults to mean)."""
    if spec is None:
        return Aggregation()
    if isinstance(spec, Mapping) and spec and set(spec) <= {"scenarios", "models"}:
        s = _form(f"{key}.scenarios", spec.get("scenarios", "mean"))
        m = _form(f"{key}.models", spec.get("models", "mean"))
        return Aggregation(s[0], s[1], m[0], m[1])
    try:
        f = _form(key, spec)
    except ValueError:
        raise ValueError(f"{key}: mean, worst, {{cvar: alpha}}, or {{scenarios: ..., models: ...}} with those "
                         f"forms, got {spec!r}") from None
    return Aggregation(f[0], f[1], f[0], f[1])


def cost_of_stats(cost: Mapping[str, Any], terms: Mapping[str, float], means: Mapping[str, float]) -> float:
    """The cost of one response from its terms (:data:`TERMS`) and its signals' mean |.| (``e``, ``u``,
    ``du``, ``y<i>``, ``x<i>``, for ``mae_product``)."""
    if "mae_product" in cost:
        f = 1.0
        for s, w in cost["mae_product"].items():
            f *= float(means[s]) ** float(w)
        return f
    return float(sum(float(w) * terms[k] for k, w in cost.items()))


def _agg(values: np.ndarray, method: str, alpha: float, weights: np.ndarray | None) -> float:
    if method == "worst":
        keep = values if weights is None else values[weights > 0]
        return float(np.max(keep))
    if method == "cvar":
        return aggregate(values, "cvar", weights=weights, alpha=alpha)
    return aggregate(values, "mean", weights=weights)


def combine(costs: np.ndarray, weights: np.ndarray, agg: Aggregation) -> tuple[float, np.ndarray]:
    """``(J, J_m)``: the cost of a candidate from ``costs`` (models, scenarios) and the scenarios' weights,
    and each model's cost ``J_m`` (its scenarios aggregated)."""
    if costs.size == 1:  # one model, one scenario: every form is the cost itself
        return float(costs[0, 0]), costs[:, 0].astype(float)
    per_model = np.array([_agg(row, agg.scenarios, agg.scenarios_alpha, weights) for row in costs])
    return _agg(per_model, agg.models, agg.models_alpha, None), per_model
