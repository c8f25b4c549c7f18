"""Aggregation over recordings and the prior of the filter objective (``metric_options``, ``prior``).

YAML (``objective:``)::

    metric: broad_mean_rmse
    metric_options:
      aggregate: cvar          # mean (default) | median | worst_k | cvar
      k: 3                     # worst_k: number of worst recordings averaged
      alpha: 0.5               # cvar: tail mass in (0, 1]
      group_balanced: true     # every group of recordings counts equally (weights of mean/median/cvar)
      groups: broad            # broad (BROAD's trials.json beside each trial, the default) or {recording: group}
      heading_offset: remove   # none (default) | remove: each recording's truth turned by its constant heading offset
    prior:
      strength: 3.0            # fitness units (deg for BROAD's metrics) per squared RMS unit-cube distance
      center: defaults         # the filter's defaults (with `fixed`), or {name: value, ...}

The aggregations are those of :mod:`objectives.attitude.aggregate` over the per-recording scores of the
metric: BROAD's total RMSE (``broad_mean_rmse``), the mean per-axis Euler RMSE (``euler_rmse_mean``) or
eq. 3.18 (``mse_1d``). The pooled metrics (``euler_mse_geomean``, ``broad_total_rmse``) have no
per-recording score and accept only the default. Without these keys the fitness is bit-identical to
the plain metric. The prior adds :func:`~objectives.attitude.aggregate.prior_penalty` to the tuning
fitness only (held-out and reported scores stay the plain metric); its distance is measured in the unit
cube of the objective's default search space (the filter's declared ranges).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from objectives.attitude.aggregate import AGGREGATIONS, aggregate, group_weights

__all__ = ["fitness_label", "AGG_KEYS", "ERROR_KEYS", "PER_RECORDING_METRICS", "RECORDING_KEYS",
           "check_metric_options", "check_prior", "aggregate_scores", "recording_groups", "ungrouped_if_missing"]

AGG_KEYS = ("aggregate", "k", "alpha", "group_balanced", "groups")
#: metric options that change the errors themselves (kept on held-out sides, unlike the aggregation)
ERROR_KEYS = ("heading_offset",)
PER_RECORDING_METRICS = ("broad_mean_rmse", "euler_rmse_mean", "mse_1d", "heading_rmse_mean", "inclination_rmse_mean")
#: per-recording metric -> its key in a recording's error metrics (``ErrorSums.as_dict``)
RECORDING_KEYS = {"broad_mean_rmse": "total_rmse_deg", "mse_1d": "mse_1d", "heading_rmse_mean": "heading_rmse_deg",
                  "inclination_rmse_mean": "inclination_rmse_deg"}


def fitness_label(metric: str, opts: Mapping[str, Any], prior: Mapping[str, Any] | None = None) -> str:
    """How the tuning fitness is made, e.g. ``broad_mean_rmse, cvar (alpha 0.5), group-balanced``."""
    parts = [metric]
    agg = opts.get("aggregate", "mean")
    if agg != "mean":
        extra = {"worst_k": f" (k {opts.get('k', 3)})", "cvar": f" (alpha {opts.get('alpha', 0.5)})"}.get(agg, "")
        parts.append(f"{agg}{extra} over recordings")
    if opts.get("group_balanced"):
        parts.append("group-balanced")
    if prior and prior.get("strength", 0):
        parts.append("plus the prior")
    return ", ".join(parts)


def check_metric_options(metric: str, opts: Mapping[str, Any]) -> None:
    """ValueError naming ``objective.metric_options.<key>`` for a bad aggregation option."""
    where = "objective.metric_options"
    method = opts.get("aggregate", "mean")
    if method not in AGGREGATIONS:
        raise ValueError(f"{where}.aggregate: unknown {method!r}; allowed: {list(AGGREGATIONS)}")
    custom = method != "mean" or bool(opts.get("group_balanced", False))
    if custom and metric not in PER_RECORDING_METRICS:
        raise ValueError(f"{where}.aggregate: {metric} pools all recordings; aggregation needs one of "
                         f"{list(PER_RECORDING_METRICS)}")
    if method == "worst_k":
        k = opts.get("k")
        if isinstance(k, bool) or not isinstance(k, int) or k < 1:
            raise ValueError(f"{where}.k: worst_k needs an integer k >= 1, got {k!r}")
    elif "k" in opts:
        raise ValueError(f"{where}.k: only used by aggregate: worst_k (got aggregate: {method})")
    if method == "cvar":
        a = opts.get("alpha")
        if isinstance(a, bool) or not isinstance(a, (int, float)) or not 0 < a <= 1:
            raise ValueError(f"{where}.alpha: cvar needs 0 < alpha <= 1, got {a!r}")
    elif "alpha" in opts:
        raise ValueError(f"{where}.alpha: only used by aggregate: cvar (got aggregate: {method})")
    if not isinstance(opts.get("group_balanced", False), bool):
        raise ValueError(f"{where}.group_balanced: expected true or false, got {opts['group_balanced']!r}")
    groups = opts.get("groups", "broad")
    if not (groups == "broad" or (isinstance(groups, Mapping) and all(isinstance(v, str) for v in groups.values()))):
        raise ValueError(f"{where}.groups: expected broad or a mapping recording -> group name, got {groups!r}")
    if "groups" in opts and not opts.get("group_balanced", False):
        raise ValueError(f"{where}.groups: only used with group_balanced: true")
    if opts.get("heading_offset", "none") not in ("none", "remove"):
        raise ValueError(f"{where}.heading_offset: expected none or remove, got {opts['heading_offset']!r}")
    if opts.get("heading_offset", "none") == "remove" and metric == "mse_1d":
        raise ValueError(f"{where}.heading_offset: mse_1d compares one tilt angle, no heading")


def check_prior(prior: Any, names: Sequence[str]) -> dict[str, Any]:
    """The validated ``prior`` section ({} when absent); ValueError naming ``objective.prior.<key>``."""
    if prior is None or prior == {}:
        return {}
    if not isinstance(prior, Mapping):
        raise ValueError(f"objective.prior: expected a mapping {{strength, center}}, got {prior!r}")
    bad = sorted(set(prior) - {"strength", "center"})
    if bad:
        raise ValueError(f"objective.prior.{bad[0]}: unknown key; allowed: center, strength")
    s = prior.get("strength")
    if isinstance(s, bool) or not isinstance(s, (int, float)) or not np.isfinite(s) or s < 0:
        raise ValueError(f"objective.prior.strength: expected a finite number >= 0, got {s!r}")
    center = prior.get("center", "defaults")
    if center != "defaults":
        if not isinstance(center, Mapping):
            raise ValueError(f"objective.prior.center: expected defaults or a mapping name -> value, got {center!r}")
        unknown = sorted(set(center) - set(names))
        if unknown:
            raise ValueError(f"objective.prior.center.{unknown[0]}: not a parameter; known: {sorted(names)}")
    return {"strength": float(s), "center": center if center == "defaults" else dict(center)}


def recording_groups(recs: Sequence[Any], groups: Any) -> dict[str, str]:
    """Recording name -> group: the given mapping, or BROAD's (``trials.json`` beside each trial file, the group
    of the trial file a recording or window was read from)."""
    names = [r.name for r in recs]
    if groups != "broad":
        missing = [n for n in names if n not in groups]
        if missing:
            raise ValueError(f"objective.metric_options.groups: no group for recording(s) {missing}")
        return {n: groups[n] for n in names}
    from objectives.attitude.trials import broad_trial_groups

    out: dict[str, str] = {}
    for r in recs:
        d = Path(r.source).parent if r.source else None
        if d is None or not (d / "trials.json").exists():
            raise ValueError(f"objective.metric_options.groups: broad, but recording {r.name!r} has no BROAD "
                             f"trials.json beside it ({r.source or 'no source'}); give groups as a mapping")
        trial = Path(r.source).stem  # a window of a trial (its own name) is in the trial's group
        out[r.name] = broad_trial_groups(d, [trial])[trial]
    return out


def aggregate_scores(scores: Sequence[float], names: Sequence[str], opts: Mapping[str, Any],
                     groups: Mapping[str, str] | None) -> float:
    """The configured aggregation of per-recording scores (NaN, a diverged recording, counts as inf)."""
    s = np.asarray(scores, float)
    s = np.where(np.isnan(s), np.inf, s)
    w = group_weights(list(names), groups) if opts.get("group_balanced", False) else None
    method = opts.get("aggregate", "mean")
    k = min(int(opts["k"]), s.size) if method == "worst_k" else None
    return aggregate(s, method, weights=w, k=k, alpha=opts.get("alpha"))


def ungrouped_if_missing(opts: Mapping[str, Any], recs: Sequence[Any]) -> tuple[dict[str, Any], list[str]]:
    """``opts`` for scoring ``recs`` and a note: a group-balanced metric whose groups ``recs`` lack (recordings
    without BROAD's ``trials.json``, names missing from a ``groups`` mapping) scores them ungrouped, with one
    line saying so; otherwise ``opts`` unchanged and no note."""
    if not opts.get("group_balanced", False):
        return dict(opts), []
    try:
        recording_groups(recs, opts.get("groups", "broad"))
    except ValueError as exc:
        out = {k: v for k, v in opts.items() if k not in ("group_balanced", "groups")}
        return out, [f"these recordings lack the run's grouping ({exc}); scored ungrouped (every recording "
                     "weighs the same)"]
    return dict(opts), []
