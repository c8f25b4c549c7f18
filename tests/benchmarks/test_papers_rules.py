"""The verdict rules of docs/papers.md (benchmarks.papers_common) on constructed rows and claims."""

import math

import pytest

from benchmarks.papers_common import (
    DIRECTION,
    MIN_SEEDS,
    NOT_REPRODUCED,
    REPRODUCED,
    SENSITIVITY,
    SPREAD_FACTOR,
    UNTESTABLE,
    Claim,
    Row,
    claim_verdict,
    iv_gain,
    iv_hull,
    iv_mean,
    iv_ratio,
    nonneg,
    printed,
    printed_range,
    spread,
    summary,
)


def row(interval, values, holds=(), **kw):
    return Row("c", "Table 1", "p", "cmd", interval, values, holds, **kw)


def test_printed_number_is_the_interval_of_its_last_digit():
    assert printed("0.73") == pytest.approx((0.725, 0.735))
    assert printed("13.0") == pytest.approx((12.95, 13.05))
    assert printed("17.453") == pytest.approx((17.4525, 17.4535))
    assert printed("1.45e-6") == pytest.approx((1.445e-6, 1.455e-6))
    assert printed("4.2689e3") == pytest.approx((4268.85, 4268.95))
    assert printed("59") == pytest.approx((58.5, 59.5))
    # the thesis's "0.5-0.6 A": from the low end's lower to the high end's upper half unit
    assert printed_range("0.5", "0.6") == pytest.approx((0.45, 0.65))
    assert nonneg(printed("0.000")) == pytest.approx((0.0, 0.0005))


def test_interval_arithmetic_contains_every_combination_of_the_ends():
    a, b = printed("2.36"), printed("0.16")
    r = iv_ratio(a, b)
    for x in a:
        for y in b:
            assert r[0] - 1e-12 <= x / y <= r[1] + 1e-12
    assert iv_ratio(a, b) == pytest.approx((2.355 / 0.165, 2.365 / 0.155))
    assert iv_mean((1.0, 2.0), (3.0, 5.0)) == (2.0, 3.5)
    assert iv_hull((1.0, 2.0), (0.5, 1.5), (3.0, 4.0)) == (0.5, 4.0)
    # the thesis's 46.8 % from 0.1049 -> 0.0558: the printed digits allow 46.7-46.9 %
    g = iv_gain(printed("0.1049"), printed("0.0558"))
    assert g[0] < 46.8 < g[1] and g[1] - g[0] < 0.2
    with pytest.raises(ValueError):
        iv_ratio((1.0, 2.0), (0.0, 1.0))


def test_reproduced_needs_the_median_and_half_of_the_seeds_inside():
    iv = (1.0, 1.2)
    assert row(iv, (1.05, 1.1, 1.1, 1.15, 1.3), (True,) * 5).verdict == REPRODUCED
    assert row(iv, (1.05, 1.1, 1.1, 1.15, 1.3)).verdict == REPRODUCED  # no direction to check
    # seeds straddle the interval (the old rule: range overlap, reproduced) without the median inside
    straddle = (0.6, 0.7, 0.75, 1.1, 1.19)
    assert row(iv, straddle, (True,) * 5).verdict == DIRECTION
    assert row(iv, straddle).verdict == NOT_REPRODUCED
    # the median inside but fewer than half of the seeds: 0.9, 0.95 | 1.1 | 1.25, 1.3 has 1 of 5 inside
    assert row(iv, (0.9, 0.95, 1.1, 1.25, 1.3)).verdict == NOT_REPRODUCED
    # the KF's q11 of the old page: range 2.83e-12 to 2.58e-11 overlapped 3.08e-12, no seed inside
    q11 = (2.83e-12, 7.2e-12, 1.44e-11, 2.1e-11, 2.58e-11)
    assert row(printed("3.08e-12"), q11).verdict == NOT_REPRODUCED


def test_a_row_with_a_wide_spread_cannot_be_reproduced():
    iv = (1.0, 1.2)
    wide = (0.55, 1.1, 1.1, 1.15, 1.19)  # median and 4 of 5 inside, but 1.19 / 0.55 > 2
    assert spread(wide) > SPREAD_FACTOR
    assert row(iv, wide, (True,) * 5).verdict == DIRECTION
    assert row(iv, wide).verdict == NOT_REPRODUCED
    assert row(iv, (0.6, 1.1, 1.1, 1.15, 1.19)).verdict == REPRODUCED  # 1.19 / 0.6 < 2
    # the FAEKF's tuned rho of the old page: 1.3-28.6 (a factor 22) around the paper's 3.53
    rho = (1.263, 3.52, 3.53, 7.6, 28.59)
    assert row(printed("3.53"), rho).verdict == NOT_REPRODUCED
    assert row((1.0, 30.0), rho).verdict == NOT_REPRODUCED  # even when every seed is inside


def test_spread_of_gains_and_of_log10_values():
    # the FAEKF against the separately tuned EKF on recording 1: 66/23/74/24/52 % lower
    gains = (66.0, 23.0, 74.0, 24.0, 52.0)
    assert spread(gains, "gain") == pytest.approx(0.77 / 0.26)
    assert row((51.0, 87.0), gains, (True,) * 5, scale="gain").verdict == DIRECTION
    assert spread((40.0, 45.0, 50.0), "gain") == pytest.approx(0.6 / 0.5)
    assert spread((7.2, 7.5), "log10") == pytest.approx(10 ** 0.3)
    assert spread((1.0, -1.0)) == math.inf and spread((1.0, math.nan)) == math.inf
    assert spread((120.0, 10.0), "gain") == math.inf  # a fraction below 0: the after value is negative
    with pytest.raises(ValueError, match="scale"):
        spread((1.0,), "linear")


def test_fewer_seeds_than_the_minimum_are_never_reproduced():
    assert row((1.0, 1.2), (1.1,) * (MIN_SEEDS - 1)).verdict == NOT_REPRODUCED
    assert row((1.0, 1.2), (1.1,) * (MIN_SEEDS - 1), (True,) * (MIN_SEEDS - 1)).verdict == DIRECTION
    assert row((1.0, 1.2), (1.1,) * MIN_SEEDS).verdict == REPRODUCED


def test_a_matching_number_does_not_rescue_a_failed_direction():
    vals = (0.316, 0.318, 0.32, 0.322, 0.33)
    assert row(printed("0.32"), vals, (True,) * 4 + (False,)).verdict == NOT_REPRODUCED
    assert row(printed("0.32"), vals, (True,) * 5).verdict == REPRODUCED


def test_the_papers_interval_and_a_stated_tolerance_widen_the_match():
    assert row(printed("0.73"), (0.735,) * 5).verdict == REPRODUCED  # the printed digits' half unit
    assert row(printed("0.73"), (0.74,) * 5).verdict == NOT_REPRODUCED
    assert row(printed("0.73"), (0.74,) * 5, tol=0.01).verdict == REPRODUCED


def test_a_diverged_seed_is_never_reproduced_in_number():
    assert row((1.0, 2.0), (1.5,) * 4 + (math.nan,), (True,) * 4 + (False,)).verdict == NOT_REPRODUCED
    assert row((1.0, 2.0), (1.5,) * 4 + (math.nan,), (True,) * 5).verdict == DIRECTION
    assert row((1.0, 2.0), (1.5,) * 4 + (math.nan,)).verdict == NOT_REPRODUCED


def test_no_paper_number_allows_direction_only():
    assert row(None, (0.1,) * 5, (True,) * 5).verdict == DIRECTION
    assert row(None, (0.1,) * 5, (True,) * 4 + (False,)).verdict == NOT_REPRODUCED


def test_untestable_only_while_the_band_contains_the_papers_value():
    assert row(printed("0.1049"), (0.0872, 0.11, 0.1302), kind="untestable").verdict == UNTESTABLE
    assert row(printed("0.1049"), (0.11, 0.12, 0.1302), kind="untestable").verdict == NOT_REPRODUCED
    assert row(printed("0.1049"), (0.0872, 0.10486), kind="untestable").verdict == UNTESTABLE  # half unit: 0.10485
    assert row(printed("0.1049"), (0.0872, 0.10484), kind="untestable").verdict == NOT_REPRODUCED
    with pytest.raises(ValueError, match="interval"):
        row(None, (0.1,), kind="untestable")


def test_sensitivity_rows_are_labelled_whatever_their_numbers_and_do_not_count_for_the_claim():
    sens = row((7.0, 7.0), (7.0,) * 5, kind="sensitivity")
    assert sens.verdict == SENSITIVITY
    good = row((1.0, 1.2), (1.1,) * 5)
    assert claim_verdict([good, sens]) == REPRODUCED
    with pytest.raises(ValueError, match="sensitivity"):
        claim_verdict([sens])
    with pytest.raises(ValueError, match="kind"):
        row((7.0, 7.0), (7.0,), kind="kind of")
    with pytest.raises(ValueError, match="direction checks"):
        row((7.0, 7.0), (7.0, 8.0), (True,))


def test_a_claim_is_reproduced_when_every_row_is_and_direction_only_when_every_sentence_holds():
    rep = row((1.0, 1.2), (1.1,) * 5)
    direc = row(None, (0.1,) * 5, (True,) * 5)
    miss = row((1.0, 1.2), (3.0,) * 5)  # a number without a sentence to check, missed
    failed = row((1.0, 1.2), (1.1,) * 5, (True,) * 4 + (False,))  # the number matches, the sentence fails once
    assert claim_verdict([rep, rep]) == REPRODUCED
    assert claim_verdict([rep, direc]) == DIRECTION
    assert claim_verdict([rep, direc, miss]) == DIRECTION  # a missed number does not contradict the sentence
    assert claim_verdict([rep, miss]) == NOT_REPRODUCED  # no sentence checked: the numbers are the claim
    assert claim_verdict([rep, direc, failed]) == NOT_REPRODUCED
    # twenty cells of one table are one claim, however many of them miss
    assert Claim("t", "paper", "text", "Table 2.5", [miss] * 20).verdict == NOT_REPRODUCED
    assert Claim("t", "paper", "text", "Table 2.5", [miss] * 19 + [failed]).verdict == NOT_REPRODUCED


def test_a_band_caps_its_claim_at_untestable_and_a_missed_band_fails_it():
    rep = row((1.0, 1.2), (1.1,) * 5)
    direc = row(None, (0.1,) * 5, (True,) * 5)
    band = row(printed("0.1049"), (0.09, 0.12), kind="untestable")
    off = row(printed("0.1049"), (0.11, 0.12), kind="untestable")
    assert claim_verdict([band]) == UNTESTABLE
    assert claim_verdict([rep, band]) == UNTESTABLE and claim_verdict([direc, band]) == UNTESTABLE
    assert claim_verdict([off]) == NOT_REPRODUCED and claim_verdict([rep, off]) == NOT_REPRODUCED
    assert claim_verdict([row((1.0, 1.2), (3.0,) * 5), band]) == NOT_REPRODUCED


def test_rows_and_claims_survive_json_with_their_verdicts():
    import json

    r = row((1.0, 1.2), (1.1, math.nan, math.inf, 1.0, 1.1), (True, False, True, True, True), note="n", unit="s")
    c = Claim("k", "paper", "text", "where", [r, row((1.0, 1.2), (1.1,) * 5)])
    back = Claim.from_dict(json.loads(json.dumps(c.to_dict(), allow_nan=False)))
    assert back.verdict == c.verdict and back.key == "k"
    b = back.rows[0]
    assert math.isnan(b.values[1]) and b.values[2] == math.inf and b.holds == r.holds
    assert (b.ours(), b.direction_cell(), b.verdict) == (r.ours(), r.direction_cell(), r.verdict)


def test_summary_gives_median_and_range():
    assert summary([3.0, 1.0, 2.0, 5.0, 4.0], "deg") == "3 deg (1 to 5, 5 seeds)"
    assert "1 diverged" in summary([1.0, math.nan, 2.0])
    band = row(printed("0.1"), (0.09, 0.12), kind="untestable", seeds="settings")
    assert band.ours() == "band 0.09 to 0.12 over 2 settings"
