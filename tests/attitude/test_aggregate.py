"""Aggregations of per-recording scores and the prior penalty (objectives.attitude.aggregate)."""

from __future__ import annotations

import numpy as np
import pytest

from objectives.attitude.aggregate import aggregate, group_weights, prior_distance, prior_penalty
from tuner.space import Real, Space

S = np.array([3.0, 1.0, 7.0, 2.0, 5.0])


def test_mean_median_match_numpy():
    rng = np.random.default_rng(0)
    for n in (1, 2, 5, 8):
        s = rng.random(n) * 10
        assert aggregate(s, "mean") == pytest.approx(np.mean(s))
        assert aggregate(s, "median") == pytest.approx(np.median(s))


def test_worst_k():
    assert aggregate(S, "worst_k", k=1) == 7.0
    assert aggregate(S, "worst_k", k=2) == 6.0
    assert aggregate(S, "worst_k", k=5) == pytest.approx(S.mean())


def test_cvar_closed_form_and_limits():
    # alpha = 0.4 of 5 equal weights: the two worst (7, 5) exactly
    assert aggregate(S, "cvar", alpha=0.4) == pytest.approx(6.0)
    # alpha = 0.3: 7 with weight 0.2 and 5 with the remaining 0.1
    assert aggregate(S, "cvar", alpha=0.3) == pytest.approx((0.2 * 7 + 0.1 * 5) / 0.3)
    assert aggregate(S, "cvar", alpha=1.0) == pytest.approx(S.mean())
    assert aggregate(S, "cvar", alpha=1e-6) == pytest.approx(7.0)
    # property: non-decreasing as the tail shrinks, between mean and max
    vals = [aggregate(S, "cvar", alpha=a) for a in np.linspace(1, 0.05, 20)]
    assert all(b >= a - 1e-12 for a, b in zip(vals, vals[1:]))


def test_weighted_mean_and_median():
    w = [0, 0, 1, 0, 1]
    assert aggregate(S, "mean", weights=w) == pytest.approx(6.0)
    assert aggregate(S, "median", weights=[0.1, 0.1, 0.6, 0.1, 0.1]) == 7.0


def test_group_weights_balance_groups():
    names = ["a", "b", "c", "d"]
    groups = {"a": "rot", "b": "rot", "c": "rot", "d": "mag"}
    w = group_weights(names, groups)
    assert w.sum() == pytest.approx(1.0)
    assert w[:3].sum() == pytest.approx(0.5) and w[3] == pytest.approx(0.5)
    # group-balanced mean = mean of group means
    s = np.array([1.0, 2.0, 3.0, 10.0])
    assert aggregate(s, "mean", weights=w) == pytest.approx((2.0 + 10.0) / 2)
    with pytest.raises(ValueError, match="no group for recording"):
        group_weights(["a", "x"], groups)


@pytest.mark.parametrize("kw, msg", [
    ({"method": "max"}, "unknown method"), ({"method": "worst_k"}, "1 <= k"), ({"method": "worst_k", "k": 6}, "1 <= k"),
    ({"method": "cvar"}, "0 < alpha"), ({"method": "cvar", "alpha": 1.5}, "0 < alpha"),
    ({"weights": [1, 1]}, "weights has 2"), ({"weights": [-1, 1, 1, 1, 1]}, ">= 0"),
])
def test_bad_options_are_refused(kw, msg):
    with pytest.raises(ValueError, match=msg):
        aggregate(S, **kw)


def test_nan_and_empty_refused():
    with pytest.raises(ValueError, match="NaN at index 1"):
        aggregate([1.0, np.nan])
    with pytest.raises(ValueError, match="empty"):
        aggregate([])


def test_prior_distance_in_log_unit_cube():
    space = Space([Real("tau", 0.1, 10.0, scale="log"), Real("g", 0.0, 4.0), Real("opt", fixed=1)])
    center = {"tau": 1.0, "g": 2.0, "opt": 1}
    assert prior_distance(center, space, center) == 0.0
    # tau 10x larger = half the log range (0.5); g unchanged: RMS over 2 dims = 0.5/sqrt(2)
    assert prior_distance({"tau": 10.0, "g": 2.0}, space, center) == pytest.approx(0.5 / np.sqrt(2))
    # symmetric in log space: 10x smaller is as far as 10x larger
    assert prior_distance({"tau": 0.1, "g": 2.0}, space, center) == pytest.approx(0.5 / np.sqrt(2))
    assert prior_penalty({"tau": 10.0, "g": 2.0}, space, center, 4.0) == pytest.approx(4.0 * 0.125)
    assert prior_penalty({"tau": 10.0, "g": 2.0}, space, center, 0.0) == 0.0
    with pytest.raises(ValueError, match="strength"):
        prior_penalty(center, space, center, -1.0)
    # a log-scaled parameter whose center is 0 (off) is measured from its lower bound
    assert prior_distance({"tau": 0.1, "g": 2.0}, space, {"tau": 0.0, "g": 2.0}) == 0.0
    with pytest.raises(ValueError, match="no value for searched"):
        prior_distance(center, space, {"tau": 1.0})
