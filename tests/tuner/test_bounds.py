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


def test_failure_reasons_are_grouped_by_what_failed_not_by_their_numbers():
    """139 overshoot failures with different values and 61 identical settling failures: counted by exact text
    the settling one looked the most frequent; grouped with the numbers masked, overshoot is, and an error
    that names two reasons counts for both."""
    from tuner.failures import failure_groups, reason_key

    over = [f"requirement violated: overshoot {10 + i * 0.1:.4g} % > 5 % (max_overshoot_pct)" for i in range(139)]
    settle = ["requirement violated: 2 % settling time inf s > 1.5 s (max_settling_time_s)"] * 61
    both = [over[0] + "; " + settle[0]]
    groups = failure_groups(over + settle + both + ["", "closed loop diverged at t=0.31 s"])
    assert [(g.key.split(":")[1].split()[0], g.count) for g in groups[:2]] == [("overshoot", 140), ("#", 62)]
    assert groups[0].example == over[0] and groups[1].example == settle[0]
    assert groups[2].key == "closed loop diverged at t=# s" and groups[2].count == 1
    assert reason_key("Ms inf > 1.4 (max_ms) on 3 of 9 models") == "Ms # > # (max_ms) on # of # models"
    assert reason_key("x1e-3 in step2 and tf.num[0]") == "x1e-3 in step2 and tf.num[#]"  # digits in names stay
    (w,) = failure_warnings(200, 200, over + settle)
    assert w.message.index("overshoot") < w.message.index("settling") and "(x139)" in w.message
