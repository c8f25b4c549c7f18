"""Warnings for parameters at a search bound (log space for log parameters) and failed evaluations."""

import math

import pytest

from tuner.bounds import bound_warnings, failure_warnings
from tuner.space import Real, Space

SPACE = Space([Real("rho", 1e-3, 1e3, "log"), Real("kp", 0.0, 100.0), Real("q_q", 1e-9, 1e-3, "log"),
               Real("mode", fixed="a")])


def test_log_parameter_distance_is_measured_in_log10():
    # rho 939 of [1e-3, 1e3]: log10(1000/939) / 6 = 0.46 % -> warned; linear distance would be 6.1 %
    ws = bound_warnings({"rho": 939.0, "kp": 50.0, "q_q": 1e-6}, SPACE)
    assert [w.param for w in ws] == ["rho"]
    w = ws[0]
    assert w.side == "high" and w.bound == 1e3
    assert w.distance == pytest.approx(math.log10(1000 / 939) / 6, rel=1e-12)
    assert "rho" in w.message and "widen" in w.message


def test_linear_parameter_and_threshold_edges():
    assert [w.side for w in bound_warnings({"kp": 98.0}, SPACE)] == ["high"]  # 2.0 % exactly
    assert bound_warnings({"kp": 97.9}, SPACE) == []
    assert [w.side for w in bound_warnings({"kp": 1.5}, SPACE)] == ["low"]
    # q_q 1.5e-9 of [1e-9, 1e-3]: log10(1.5) / 6 = 2.9 % -> not within 2 %, within 3 %
    assert bound_warnings({"q_q": 1.5e-9}, SPACE) == []
    assert [w.param for w in bound_warnings({"q_q": 1.5e-9}, SPACE, tol=0.03)] == ["q_q"]


def test_fixed_missing_and_nonnumeric_values_are_skipped():
    assert bound_warnings({"mode": "a", "kp": "abc", "rho": float("nan")}, SPACE) == []
    with pytest.raises(ValueError, match="tol"):
        bound_warnings({}, SPACE, tol=0.7)


def test_failure_warning_names_the_most_frequent_errors():
    assert failure_warnings(0, 10) == []
    (w,) = failure_warnings(3, 12, ["fell at t=1", "fell at t=1", "diverged", ""])
    assert w.kind == "failed" and w.value == 3 and w.distance == 0.25
    assert w.message.startswith("3 of 12 evaluations failed (25.0%)")
    assert w.message.index("fell at t=1 (x2)") < w.message.index("diverged (x1)")
