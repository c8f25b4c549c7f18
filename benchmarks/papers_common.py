"""Claims, rows and the verdict rules of ``benchmarks.papers`` (docs/papers.md, docs/papers.json).

A :class:`Claim` is one statement of a seed paper (in its words, with where it stands); its
:class:`Row` objects are the numbers that test it: the paper's number as the interval its printed
digits allow, our values over seeds (or recordings, or settings), whether the paper's own sentence
holds on each of them, and the command that measures it. :func:`verdict` turns a row's numbers into
its verdict by :data:`RULES`, :func:`claim_verdict` a claim's rows into the claim's; docs/papers.md
prints the rules above the tables, and nothing else decides a verdict.
"""

from __future__ import annotations

import math
import statistics
from collections.abc import Sequence
from dataclasses import asdict, dataclass, field
from typing import Any

REPRODUCED = "reproduced"
DIRECTION = "direction only"
NOT_REPRODUCED = "not reproduced"
UNTESTABLE = "not testable from the text"
SENSITIVITY = "sensitivity study"
#: claim verdicts from strongest to weakest (:func:`claim_verdict`)
CLAIM_VERDICTS = (REPRODUCED, DIRECTION, UNTESTABLE, NOT_REPRODUCED)
_RANK = {v: i for i, v in enumerate(reversed(CLAIM_VERDICTS))}

#: a row can be reproduced only over at least this many seeds
MIN_SEEDS = 5
#: our seeds may spread over at most this factor (largest / smallest of the row's positive quantity,
#: see :func:`spread`); wider, and the number is not pinned down: the verdict is capped at direction only
SPREAD_FACTOR = 2.0
#: tolerance of a time measured on the closed loop's 100 Hz sample grid (Table 2.4's times): one
#: sample, since a rise or settling time is the first sample past a threshold
TIME_TOL_S = 0.01
#: "approximately the same" / "approximately equal" where the paper gives no number: within 10 %
ABOUT_EQUAL = 0.10
#: "much higher" where the paper gives no number: at least twice
MUCH = 2.0

SCALES = ("ratio", "gain", "log10")
KINDS = ("claim", "sensitivity", "untestable")

RULES = f"""## Verdict rules (computed by `benchmarks/papers_common.py`)

Every row gives the paper's number as the interval its printed digits allow (a printed 0.73 is
0.725-0.735, a printed range 0.5-0.6 is 0.45-0.65; a ratio or mean of printed numbers is computed
from those intervals), our values over seeds (tuning seeds, recording seeds, sensor-noise seeds or
timing rounds, as the row says) as median and range, and, where the paper states one, a per-seed
check of the paper's own sentence (its "direction": who is better, which way a value moves, "almost
constant", "about the same"). A check that holds by construction (tuning improves on its start
values; a value within some factor of the paper's) is no direction. A row's verdict is computed from
its numbers alone:

1. **{REPRODUCED}**: over at least {MIN_SEEDS} seeds, all finite, the **median** lies inside the paper's
   interval widened by the row's stated tolerance (zero unless the row names one: {TIME_TOL_S} s for times
   on the 100 Hz sample grid), **at least half of the seeds** lie inside it, the seeds **spread by at most
   a factor {SPREAD_FACTOR:g}** (largest / smallest value; for an improvement in % the remaining fraction
   1 - gain / 100, for a log10 value 10 to the difference), and the direction, where the row has
   one, holds on every seed. A wider spread caps the row at direction only, however its median falls.
2. **{DIRECTION}**: otherwise, the row has a direction and it holds on every seed. Where the paper
   prints no number (a missing figure, a sentence) only this verdict is possible.
3. **{NOT_REPRODUCED}**: otherwise, and for a row whose band (rule 5) misses the paper's value.
4. **{SENSITIVITY}**: the row's setting was read off the paper's result (not from its text); it shows
   how much that setting moves the number and is not a reproduction; it does not count for its claim.
5. **{UNTESTABLE}**: the text leaves open settings that move our number; the row gives our band over
   them. It is this verdict only while the band contains the paper's value: a band that misses it is
   {NOT_REPRODUCED}.

Words without a number: "about the same" / "approximately equal" is within {100 * ABOUT_EQUAL:g} %; "much
higher" is at least {MUCH:g}x.

**A claim** (the counts at the top are by claim: a table of twenty cells is one claim) is, from its rows
(sensitivity rows left out): **{REPRODUCED}** when every row is; **{DIRECTION}** when not, but rows check
the paper's sentence and every such check holds on every seed (a number that misses does not contradict
the sentence); **{NOT_REPRODUCED}** when a check fails on some seed, or no row checks a sentence and a
number misses. A claim with a rule-5 row is at best {UNTESTABLE}, and {NOT_REPRODUCED} when its band misses.
"""


# --------------------------------------------------------------------------------------------------
# the paper's numbers as intervals
# --------------------------------------------------------------------------------------------------
def printed(text: str) -> tuple[float, float]:
    """Interval a printed decimal stands for: ``'0.73'`` -> (0.725, 0.735), ``'1.45e-6'`` -> its half unit."""
    t = text.strip().lower()
    mant, _, exp = t.partition("e")
    decimals = len(mant.partition(".")[2])
    half = 0.5 * 10.0 ** (-decimals) * 10.0 ** (int(exp) if exp else 0)
    v = float(t)
    return v - half, v + half


def printed_range(low: str, high: str) -> tuple[float, float]:
    """Interval a printed range stands for: ``('0.5', '0.6')`` (the text's "0.5-0.6 A") -> (0.45, 0.65)."""
    return printed(low)[0], printed(high)[1]


def nonneg(iv: tuple[float, float]) -> tuple[float, float]:
    """``iv`` clipped at 0 (a printed 0.000 std is 0-0.0005, not -0.0005-0.0005)."""
    return max(iv[0], 0.0), max(iv[1], 0.0)


def iv_mean(*ivs: tuple[float, float]) -> tuple[float, float]:
    """Interval of the mean of intervals."""
    return sum(i[0] for i in ivs) / len(ivs), sum(i[1] for i in ivs) / len(ivs)


def iv_ratio(a: tuple[float, float], b: tuple[float, float]) -> tuple[float, float]:
    """Interval of a / b for a >= 0 and b > 0."""
    if a[0] < 0 or b[0] <= 0:
        raise ValueError(f"iv_ratio needs a >= 0 and b > 0, got {a}, {b}")
    return a[0] / b[1], a[1] / b[0]


def iv_gain(before: tuple[float, float], after: tuple[float, float]) -> tuple[float, float]:
    """Interval of the improvement 100 (1 - after / before) in %."""
    r = iv_ratio(after, before)
    return 100.0 * (1.0 - r[1]), 100.0 * (1.0 - r[0])


def iv_hull(*ivs: tuple[float, float]) -> tuple[float, float]:
    """Smallest interval holding all of ``ivs`` (the spread of a claim over several datasets)."""
    return min(i[0] for i in ivs), max(i[1] for i in ivs)


# --------------------------------------------------------------------------------------------------
# rows, claims, verdicts
# --------------------------------------------------------------------------------------------------
def spread(values: Sequence[float], scale: str = "ratio") -> float:
    """Largest / smallest of the positive quantity behind ``values`` (inf when it is not positive).

    ``ratio``: the values themselves (errors, times, ratios, parameter values); ``gain``: improvements
    in %, whose quantity is the remaining fraction ``1 - gain / 100`` (66 % and 23 % are 0.34 and 0.77, a
    factor 2.3); ``log10``: log10 of a positive quantity, whose factor is ``10 ** (max - min)``.
    """
    v = [float(x) for x in values]
    if not v or not all(math.isfinite(x) for x in v):
        return math.inf
    if scale == "log10":
        return 10.0 ** (max(v) - min(v))
    if scale == "gain":
        v = [1.0 - x / 100.0 for x in v]
    elif scale != "ratio":
        raise ValueError(f"scale must be one of {SCALES}, got {scale!r}")
    return max(v) / min(v) if min(v) > 0 else math.inf


@dataclass
class Row:
    """One line of a claim's table.

    Attributes
    ----------
    label : str
        What the row measures (independent of the budget, so a smoke run has the same rows).
    where : str
        Where in the paper (table, equation, section, paragraph).
    paper : str
        The paper's number as printed (or its words, when it prints none).
    command : str
        How to measure the row.
    interval : (float, float) or None
        The paper's number as the interval of its printed digits; None when it prints none.
    values : tuple of float
        Our values over seeds (or recordings, settings, timing rounds), in the unit of ``interval``.
    holds : tuple of bool
        Per value: does the paper's sentence (``direction``) hold? Empty: the row has no direction.
    direction : str
        The paper's sentence checked per seed, in words ('-' when none).
    tol : float
        Tolerance widening ``interval`` (0 unless stated, see :data:`RULES`).
    kind : str
        ``"claim"`` (rules 1-3), ``"sensitivity"`` (rule 4) or ``"untestable"`` (rule 5).
    scale : str
        How :func:`spread` reads ``values``: ``"ratio"``, ``"gain"`` or ``"log10"``.
    unit, seeds : str
        Unit of the values and what the seeds are.
    note : str
        Words after the numbers in the "ours" column (e.g. which filter won on each seed).
    verdict : str
        Computed by :func:`verdict` (not an argument).
    """

    label: str
    where: str
    paper: str
    command: str
    interval: tuple[float, float] | None = None
    values: tuple[float, ...] = ()
    holds: tuple[bool, ...] = ()
    direction: str = "-"
    tol: float = 0.0
    kind: str = "claim"
    scale: str = "ratio"
    unit: str = ""
    seeds: str = "seeds"
    note: str = ""
    verdict: str = field(default="", init=False)

    def __post_init__(self) -> None:
        self.values = tuple(float(v) for v in self.values)
        self.holds = tuple(bool(h) for h in self.holds)
        if self.interval is not None:
            self.interval = (float(self.interval[0]), float(self.interval[1]))
        if self.kind not in KINDS:
            raise ValueError(f"Row.kind must be one of {KINDS}, got {self.kind!r}")
        if self.scale not in SCALES:
            raise ValueError(f"Row.scale must be one of {SCALES}, got {self.scale!r}")
        if self.holds and len(self.holds) != len(self.values):
            raise ValueError(f"{self.label}: {len(self.holds)} direction checks for {len(self.values)} values")
        if self.kind == "untestable" and self.interval is None:
            raise ValueError(f"{self.label}: an untestable row needs the paper's interval to compare its band with")
        self.verdict = verdict(self)

    def ours(self) -> str:
        """The "ours" cell: median and range (a band for an untestable row), then the note."""
        if self.kind == "untestable":
            u = f" {self.unit}" if self.unit else ""
            finite = [v for v in self.values if math.isfinite(v)]
            text = (f"band {fmt(min(finite))} to {fmt(max(finite))}{u} over {len(self.values)} {self.seeds}"
                    if finite else f"diverged on all {len(self.values)}")
        else:
            text = summary(self.values, self.unit, self.seeds)
        return text + (f"; {self.note}" if self.note else "")

    def direction_cell(self) -> str:
        """The direction and on how many seeds it holds."""
        return self.direction + (f": {sum(self.holds)} of {len(self.holds)}" if self.holds else "")

    def to_dict(self) -> dict[str, Any]:
        d = asdict(self)
        d["values"] = [_num(v) for v in self.values]
        d["interval"] = None if self.interval is None else [_num(v) for v in self.interval]
        d["holds"] = list(self.holds)
        return d

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> Row:
        d = dict(d)
        d.pop("verdict", None)
        d["values"] = tuple(_float(v) for v in d["values"])
        d["interval"] = None if d["interval"] is None else tuple(_float(v) for v in d["interval"])
        return cls(**d)


def in_band(values: Sequence[float], row: Row) -> list[bool]:
    """Per value: inside the row's interval widened by its tolerance?"""
    if row.interval is None:
        return [False] * len(values)
    lo, hi = row.interval[0] - row.tol, row.interval[1] + row.tol
    return [lo <= v <= hi for v in values]


def matches_in_number(row: Row) -> bool:
    """Rule 1 without the direction: enough finite seeds, median and half of the seeds inside the
    widened interval, spread within :data:`SPREAD_FACTOR`."""
    v = row.values
    if row.interval is None or len(v) < MIN_SEEDS or not all(math.isfinite(x) for x in v):
        return False
    inside = in_band(v, row)
    return (in_band([statistics.median(v)], row)[0] and 2 * sum(inside) >= len(v)
            and spread(v, row.scale) <= SPREAD_FACTOR)


def verdict(row: Row) -> str:
    """The row's verdict by :data:`RULES` (from its numbers only)."""
    if row.kind == "sensitivity":
        return SENSITIVITY
    if row.kind == "untestable":
        finite = [v for v in row.values if math.isfinite(v)]
        lo, hi = row.interval[0] - row.tol, row.interval[1] + row.tol
        return UNTESTABLE if finite and min(finite) <= hi and max(finite) >= lo else NOT_REPRODUCED
    direction_ok = all(row.holds)  # True when the row has no direction
    if direction_ok and matches_in_number(row):
        return REPRODUCED
    if row.holds and direction_ok:
        return DIRECTION
    return NOT_REPRODUCED


@dataclass
class Claim:
    """One claim of a paper and the rows that test it.

    Attributes
    ----------
    key : str
        Short stable name (``ccf-gains``); the JSON and the tests refer to claims by it.
    paper : str
        The seed (``Narkhede 2021 (CCF)``).
    text : str
        The claim, as close to the paper's words as a line allows (quotes are the paper's).
    where : str
        Where the paper makes it.
    rows : list of Row
    verdict : str
        Computed by :func:`claim_verdict` (not an argument).
    """

    key: str
    paper: str
    text: str
    where: str
    rows: list[Row]
    verdict: str = field(default="", init=False)

    def __post_init__(self) -> None:
        self.rows = list(self.rows)
        self.verdict = claim_verdict(self.rows)

    def to_dict(self) -> dict[str, Any]:
        return {"key": self.key, "paper": self.paper, "text": self.text, "where": self.where,
                "verdict": self.verdict, "rows": [r.to_dict() for r in self.rows]}

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> Claim:
        return cls(d["key"], d["paper"], d["text"], d["where"], [Row.from_dict(r) for r in d["rows"]])


def claim_verdict(rows: Sequence[Row]) -> str:
    """A claim's verdict from its rows' (sensitivity studies left out), by the last paragraph of :data:`RULES`.

    Reproduced when every row is; direction only when not, but rows check the paper's sentence and each of
    them holds on every seed (a number that misses does not contradict the sentence); not reproduced when a
    sentence fails on some seed, or no row checks one and a number misses. Untestable rows (rule 5) cap the
    claim at not testable, and a band that misses the paper's value makes it not reproduced.
    """
    counted = [r for r in rows if r.kind != "sensitivity"]
    if not counted:
        raise ValueError("a claim needs at least one row that is not a sensitivity study")
    bands = [r for r in counted if r.kind == "untestable"]
    if any(r.verdict == NOT_REPRODUCED for r in bands):
        return NOT_REPRODUCED
    tested = [r for r in counted if r.kind == "claim"]
    if all(r.verdict == REPRODUCED for r in tested):
        v = REPRODUCED
    elif any(r.holds for r in tested) and all(all(r.holds) for r in tested if r.holds):
        v = DIRECTION
    else:
        v = NOT_REPRODUCED
    return min((v, UNTESTABLE), key=_RANK.__getitem__) if bands else v


# --------------------------------------------------------------------------------------------------
# numbers in words, and in JSON
# --------------------------------------------------------------------------------------------------
def fmt(v: float) -> str:
    """A number in 4 significant digits (3 in exponent form)."""
    if not math.isfinite(v):
        return "diverged" if math.isnan(v) else str(v)
    a = abs(v)
    if a != 0 and (a < 1e-3 or a >= 1e5):
        return f"{v:.3g}"
    return f"{v:.4g}"


def summary(values: Sequence[float], unit: str = "", seeds: str = "") -> str:
    """``median unit (lo to hi, n seeds)`` of ``values``."""
    if not values:
        return "-"
    u = f" {unit}" if unit else ""
    if len(values) == 1:
        return f"{fmt(values[0])}{u}"
    finite = [v for v in values if math.isfinite(v)]
    bad = len(values) - len(finite)
    if not finite:
        return f"diverged on all {len(values)}"
    med = statistics.median(finite)
    s = f"{fmt(med)}{u} ({fmt(min(finite))} to {fmt(max(finite))}, {len(values)} {seeds or 'seeds'}"
    return s + (f", {bad} diverged)" if bad else ")")


def _num(v: float) -> float | str:
    """A float for JSON: non-finite values as the strings ``nan``, ``inf``, ``-inf`` (JSON has no NaN)."""
    v = float(v)
    return v if math.isfinite(v) else str(v)


def _float(v: float | str) -> float:
    return float(v)
