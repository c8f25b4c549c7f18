"""Aggregation of per-recording scores into one fitness, and a prior penalty toward a given point.

Tuning on a handful of recordings with the plain mean lets a few easy, similar recordings decide
the parameters and lets the optimiser trade one bad recording for several slightly better ones.
These pure functions give the alternatives the filter objective (:mod:`objectives.attitude.objective`,
also inside the engine's cross-validation, :mod:`tuner.cv`) uses; all take per-recording scores where
lower is better.

Aggregations (``aggregate(scores, method, ...)``), each optionally weighted by ``weights`` (>= 0,
normalised to sum 1; equal weights if omitted):

``mean``        weighted mean ``sum_i w_i s_i``.
``median``      weighted median: the smallest score whose cumulative weight reaches 1/2 (the lower
                median for an even number of equal weights is averaged with the upper one, so the
                unweighted case equals :func:`numpy.median`).
``worst_k``     mean of the ``k`` largest scores (unweighted; ``k = 1`` is the maximum).
``cvar``        conditional value at risk of the upper tail of mass ``alpha`` in (0, 1]: the
                weighted mean of the worst scores that together carry weight ``alpha``, the score
                on the boundary counted with the fraction of its weight that fits (Rockafellar &
                Uryasev 2002, discrete form). ``alpha = 1`` is the mean; ``alpha -> 0`` the maximum.

Group balance: :func:`group_weights` gives each group the same total weight, split equally among
its members, so a group of five similar trials counts as much as a group of one.

Prior: :func:`prior_distance` is the root-mean-square distance of two parameter points in the unit
cube of a :class:`tuner.space.Space` (log-scaled parameters are therefore compared in log10 space,
normalised by the width of their range); :func:`prior_penalty` is ``strength * distance**2``, a
Gaussian prior of standard deviation ``1/sqrt(2 strength)`` cube widths in every free dimension.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from tuner.space import Space

__all__ = ["AGGREGATIONS", "aggregate", "group_weights", "prior_distance", "prior_penalty"]

AGGREGATIONS = ("mean", "median", "worst_k", "cvar")


def _scores(scores: Any) -> np.ndarray:
    s = np.asarray(scores, dtype=float).reshape(-1)
    if s.size == 0:
        raise ValueError("aggregate: scores is empty; need at least one per-recording score")
    if np.isnan(s).any():
        raise ValueError(f"aggregate: scores hold NaN at index {int(np.argmax(np.isnan(s)))}; "
                         "score a failed recording with a finite penalty")
    return s


def _weights(weights: Any, n: int) -> np.ndarray:
    if weights is None:
        return np.full(n, 1.0 / n)
    w = np.asarray(weights, dtype=float).reshape(-1)
    if w.shape != (n,):
        raise ValueError(f"aggregate: weights has {w.size} entries, scores has {n}")
    if not np.isfinite(w).all() or (w < 0).any() or w.sum() <= 0:
        raise ValueError(f"aggregate: weights must be finite, >= 0 and not all 0, got {w.tolist()}")
    return w / w.sum()


def aggregate(scores: Sequence[float] | np.ndarray, method: str = "mean", *, weights: Any = None,
              k: int | None = None, alpha: float | None = None) -> float:
    """One number from per-recording scores (lower is better); see the module docstring.

    Parameters
    ----------
    scores : (n,) array_like
        Per-recording scores, finite or ``inf`` (NaN is refused: failures need a penalty value).
    method : {"mean", "median", "worst_k", "cvar"}
    weights : (n,) array_like, optional
        Non-negative weights (e.g. :func:`group_weights`); ignored by ``worst_k``.
    k : int
        Number of worst scores averaged by ``worst_k`` (1 <= k <= n).
    alpha : float
        Tail mass of ``cvar``, 0 < alpha <= 1.

    Raises
    ------
    ValueError
        Unknown method, missing or out-of-range ``k``/``alpha``, bad weights, empty or NaN scores.
    """
    s = _scores(scores)
    n = s.size
    if method not in AGGREGATIONS:
        raise ValueError(f"aggregate: unknown method {method!r}; allowed: {list(AGGREGATIONS)}")
    if method == "worst_k":
        if k is None or not 1 <= int(k) <= n:
            raise ValueError(f"aggregate: worst_k needs 1 <= k <= {n} (number of scores), got k={k!r}")
        return float(np.mean(np.sort(s)[::-1][: int(k)]))
    w = _weights(weights, n)
    if method == "mean":
        return float(np.sum(w * s))
    if method == "median":
        order = np.argsort(s, kind="stable")
        cw = np.cumsum(w[order])
        i = int(np.searchsorted(cw, 0.5 - 1e-12))
        if abs(cw[i] - 0.5) <= 1e-12 and i + 1 < n:  # exactly half: midpoint, as numpy.median
            return float(0.5 * (s[order[i]] + s[order[i + 1]]))
        return float(s[order[i]])
    if alpha is None or not 0.0 < float(alpha) <= 1.0:
        raise ValueError(f"aggregate: cvar needs 0 < alpha <= 1 (tail mass), got alpha={alpha!r}")
    a = float(alpha)
    order = np.argsort(-s, kind="stable")
    total, acc = 0.0, 0.0
    for i in order:
        take = min(w[i], a - acc)
        if take <= 0:
            break
        total += take * s[i]
        acc += take
    return float(total / a)


def group_weights(names: Sequence[str], groups: Mapping[str, str]) -> np.ndarray:
    """Weights (n,) summing to 1 that give every group present in ``names`` the same total weight.

    Parameters
    ----------
    names : sequence of str
        Recording names, in the order of the scores they will weight.
    groups : mapping
        Recording name -> group name (e.g. :func:`objectives.attitude.trials.broad_trial_groups`).

    Raises
    ------
    ValueError
        A name has no group.
    """
    missing = [n for n in names if n not in groups]
    if missing:
        raise ValueError(f"group_weights: no group for recording(s) {missing}; known: {sorted(groups)}")
    g = [groups[n] for n in names]
    present = sorted(set(g))
    counts = {x: g.count(x) for x in present}
    return np.array([1.0 / (len(present) * counts[x]) for x in g])


def prior_distance(params: Mapping[str, Any], space: Space, center: Mapping[str, Any]) -> float:
    """RMS distance of ``params`` from ``center`` in ``space``'s unit cube (0 = same point, <= 1).

    Only free (searched) parameters count; a center value outside the bounds is clipped onto the
    cube's face (as :meth:`tuner.space.Real.to_unit`), a center value <= 0 of a log-scaled parameter
    (e.g. an integral gain that defaults to 0) onto its lower bound. A space without free parameters gives 0.
    """
    if space.dim == 0:
        return 0.0
    free = [p.name for p in space.free]
    missing = [n for n in free if n not in center]
    if missing:
        raise ValueError(f"prior: center has no value for searched parameter(s) {missing}")
    u = space.encode({n: params[n] for n in free})
    u0 = space.encode({p.name: (p.low if p.scale == "log" and float(center[p.name]) <= 0 else center[p.name])
                       for p in space.free})
    return float(np.sqrt(np.mean((u - u0) ** 2)))


def prior_penalty(params: Mapping[str, Any], space: Space, center: Mapping[str, Any], strength: float) -> float:
    """``strength * prior_distance(params, space, center)**2``, in the units of the fitness.

    ``strength`` is the penalty of a move across the whole cube in every free dimension (e.g. in
    degrees of RMSE for BROAD's metric); 0 disables the prior.
    """
    if not np.isfinite(strength) or strength < 0:
        raise ValueError(f"prior: strength must be a finite number >= 0, got {strength!r}")
    if strength == 0:
        return 0.0
    return float(strength) * prior_distance(params, space, center) ** 2
