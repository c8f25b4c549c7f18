"""The verdict rules of docs/papers.md (benchmarks.papers_common) on constructed rows, and the page's shape."""

import math

import pytest

from benchmarks import papers
from benchmarks.papers_common import (
    DIRECTION,
    NOT_REPRODUCED,
    REPRODUCED,
    SENSITIVITY,
    UNTESTABLE,
    Row,
    iv_gain,
    iv_hull,
    iv_mean,
    iv_ratio,
    printed,
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


def test_reproduced_when_the_papers_number_lies_within_our_seed_range():
    assert row((7.0, 7.0), (5.0, 9.0, 6.0), (True,) * 3).verdict == REPRODUCED
    assert row((7.0, 7.0), (7.5, 9.0), (True, True)).verdict == DIRECTION  # outside the range: direction only
    assert row((7.0, 7.0), (7.5, 9.0), (True, False)).verdict == NOT_REPRODUCED  # one seed against the claim
    assert row((7.0, 7.0), (7.5, 9.0)).verdict == NOT_REPRODUCED  # no direction to check
    assert row((7.0, 7.0), (5.0, 9.0)).verdict == REPRODUCED


def test_a_matching_number_does_not_rescue_a_failed_direction():
    # the fuzzy scheme's peak current matches the thesis's while it is above the PID's on some seed
    assert row(printed("0.32"), (0.18, 0.3195), (False, True)).verdict == NOT_REPRODUCED
    assert row(printed("0.32"), (0.18, 0.3195), (True, True)).verdict == REPRODUCED


def test_the_papers_interval_and_a_stated_tolerance_widen_the_match():
    assert row(printed("0.73"), (0.735, 0.80)).verdict == REPRODUCED  # the printed digits' half unit
    assert row(printed("0.73"), (0.74, 0.80)).verdict == NOT_REPRODUCED
    assert row(printed("0.73"), (0.74, 0.80), tol=0.01).verdict == REPRODUCED
    assert row((0.0, 0.0145), (0.02, 0.03), (True, True)).verdict == DIRECTION


def test_a_diverged_seed_is_never_reproduced_in_number():
    assert row((1.0, 2.0), (1.5, math.nan), (True, False)).verdict == NOT_REPRODUCED
    assert row((1.0, 2.0), (1.5, math.nan), (True, True)).verdict == DIRECTION
    assert row((1.0, 2.0), (1.5, math.nan)).verdict == NOT_REPRODUCED


def test_no_paper_number_allows_direction_only():
    assert row(None, (0.1, 0.2), (True, True)).verdict == DIRECTION
    assert row(None, (0.1, 0.2), (True, False)).verdict == NOT_REPRODUCED


def test_sensitivity_and_untestable_rows_are_labelled_whatever_their_numbers():
    assert row((7.0, 7.0), (7.0,), kind="sensitivity").verdict == SENSITIVITY
    assert row((7.0, 7.0), (7.0,), kind="untestable").verdict == UNTESTABLE
    with pytest.raises(ValueError, match="kind"):
        row((7.0, 7.0), (7.0,), kind="kind of")
    with pytest.raises(ValueError, match="direction checks"):
        row((7.0, 7.0), (7.0, 8.0), (True,))


def test_summary_gives_median_and_range():
    assert summary([3.0, 1.0, 2.0, 5.0, 4.0], "deg") == "3 deg (1 to 5, 5 seeds)"
    assert "1 diverged" in summary([1.0, math.nan, 2.0])


def test_page_has_header_rules_and_one_line_per_row(tmp_path):
    rows = [row((1.0, 1.0), (1.0, 2.0), (True, True)), Row("c2", "Fig. 9", "-", "cmd two", None, (0.1,), (False,))]
    out = tmp_path / "papers.md"
    head = papers.header(papers.BUDGETS["smoke"], 12.3, "abc+dirty", "cpu x", "2026-01-01 00:00:00 UTC")
    papers.write(rows, out, head, "notes\n")
    text = out.read_text()
    assert "- wall time: 12 s" in text and "- commit: abc+dirty" in text and "- machine: cpu x" in text
    assert text.index("## Verdict rules") < text.index("## Claims")
    assert text.count("\n| c |") == 1 and text.count("\n| c2 |") == 1
    assert f"**{REPRODUCED}**" in text and f"**{NOT_REPRODUCED}**" in text and text.endswith("notes\n")


def test_commit_id_names_head_and_dirt():
    cid = papers.commit_id()
    assert len(cid.split("+")[0]) == 40 and cid.endswith(("+dirty", cid.split("+")[0]))
