"""Rows, verdict rules and run helpers of ``benchmarks.papers`` (docs/papers.md).

A row holds one claim of a seed paper: where it stands in the paper, the paper's number as the
interval its printed digits allow, our values over seeds (or recordings), whether the claimed
direction holds on each of them, and the command that measures it. :func:`verdict` turns those
numbers into the verdict by :data:`RULES`, which docs/papers.md prints above the table; nothing
else decides a verdict.
"""

from __future__ import annotations

import math
import statistics
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml

ROOT = Path(__file__).resolve().parents[1]
PAPERS = ROOT / "configs" / "papers"

REPRODUCED = "reproduced in number"
DIRECTION = "direction only"
NOT_REPRODUCED = "not reproduced"
SENSITIVITY = "sensitivity study"
UNTESTABLE = "not testable from the text"

#: tolerance of a time measured on the closed loop's 100 Hz sample grid (Table 2.4's times): one
#: sample, since a rise or settling time is the first sample past a threshold
TIME_TOL_S = 0.01
#: a tuned parameter value "holds the direction" when it lies within this factor of the paper's (the
#: same decade); the papers' tuned values come from other data, so only their order is comparable
VALUE_FACTOR = 10.0

RULES = f"""## Verdict rules (fixed before any result; `benchmarks/papers_common.py`)

Every row gives the paper's number as the interval its printed digits allow (a printed 0.73 is
0.725-0.735; a ratio or mean of printed numbers is computed from those intervals), our values over
at least five seeds (tuning seeds, recording seeds or sensor-noise seeds, as the row says) as median
and range, and a per-seed check of the direction the paper claims. The verdict is computed from
those numbers alone:

1. **{REPRODUCED}**: the paper's interval, widened by the row's stated tolerance (zero unless
   the row names one: {TIME_TOL_S} s for times on the 100 Hz sample grid), overlaps our range over seeds,
   and the claimed direction, where the row has one, holds on every seed (a matching number with
   the comparison the paper draws from it failing is not a reproduction).
2. **{DIRECTION}**: otherwise, the claimed direction (the row's "direction" column) holds on
   every seed. For a tuned parameter value the direction is "within a factor {VALUE_FACTOR:g} of the
   paper's value"; where the paper prints no number (a missing figure) only this verdict is possible.
3. **{NOT_REPRODUCED}**: otherwise.
4. **{SENSITIVITY}**: the row's setting was read off the paper's result (not from its text); it
   shows how much that setting moves the number and is not a reproduction.
5. **{UNTESTABLE}**: the text leaves open settings that move our number across the paper's; the
   row gives the band over them.
"""


def printed(text: str) -> tuple[float, float]:
    """Interval a printed decimal stands for: ``'0.73'`` -> (0.725, 0.735), ``'1.45e-6'`` -> its half unit."""
    t = text.strip().lower()
    mant, _, exp = t.partition("e")
    decimals = len(mant.partition(".")[2])
    half = 0.5 * 10.0 ** (-decimals) * 10.0 ** (int(exp) if exp else 0)
    v = float(t)
    return v - half, v + half


def iv_mean(*ivs: tuple[float, float]) -> tuple[float, float]:
    """Interval of the mean of intervals."""
    return sum(i[0] for i in ivs) / len(ivs), sum(i[1] for i in ivs) / len(ivs)


def iv_ratio(a: tuple[float, float], b: tuple[float, float]) -> tuple[float, float]:
    """Interval of a / b for positive intervals."""
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


@dataclass
class Row:
    """One line of docs/papers.md.

    Attributes
    ----------
    claim : str
        The claim in words (independent of the budget, so a smoke run has the same rows).
    where : str
        Where in the paper (table, equation, section).
    paper : str
        The paper's number as printed (or '-' when the paper prints none).
    ours : str
        Our numbers in words; filled from ``values`` by :func:`summary` when empty.
    command : str
        How to measure the row.
    interval : (float, float) or None
        The paper's number as an interval of its printed digits; None when it prints none.
    values : tuple of float
        Our values over seeds (or recordings), in the unit of ``interval``.
    holds : tuple of bool
        Per value: does the direction the paper claims hold?
    direction : str
        The claimed direction in words.
    tol : float
        Tolerance widening ``interval`` (0 unless stated, see :data:`RULES`).
    kind : str
        ``"claim"`` (a verdict by rules 1-3), ``"sensitivity"`` or ``"untestable"``.
    unit, seeds : str
        Unit of the values and what the seeds are.
    """

    claim: str
    where: str
    paper: str
    command: str
    interval: tuple[float, float] | None = None
    values: tuple[float, ...] = ()
    holds: tuple[bool, ...] = ()
    direction: str = "-"
    tol: float = 0.0
    kind: str = "claim"
    unit: str = ""
    seeds: str = ""
    ours: str = ""
    verdict: str = field(default="", init=False)

    def __post_init__(self) -> None:
        self.values = tuple(float(v) for v in self.values)
        self.holds = tuple(bool(h) for h in self.holds)
        if self.kind not in ("claim", "sensitivity", "untestable"):
            raise ValueError(f"Row.kind must be claim, sensitivity or untestable, got {self.kind!r}")
        if self.holds and len(self.holds) != len(self.values):
            raise ValueError(f"{self.claim}: {len(self.holds)} direction checks for {len(self.values)} values")
        if not self.ours:
            self.ours = summary(self.values, self.unit, self.seeds)
        self.verdict = verdict(self)


def verdict(row: Row) -> str:
    """The row's verdict by :data:`RULES` (from its numbers only)."""
    if row.kind == "sensitivity":
        return SENSITIVITY
    if row.kind == "untestable":
        return UNTESTABLE
    vals = [v for v in row.values if math.isfinite(v)]
    direction_ok = all(row.holds)  # True when the row has no direction
    if row.interval is not None and vals and len(vals) == len(row.values) and direction_ok:
        lo, hi = row.interval[0] - row.tol, row.interval[1] + row.tol
        if min(vals) <= hi and max(vals) >= lo:
            return REPRODUCED
    if row.holds and direction_ok:
        return DIRECTION
    return NOT_REPRODUCED


def fmt(v: float) -> str:
    """A number in 3-4 significant digits."""
    if not math.isfinite(v):
        return "diverged" if math.isnan(v) else str(v)
    a = abs(v)
    if a != 0 and (a < 1e-3 or a >= 1e5):
        return f"{v:.3g}"
    return f"{v:.4g}" if a < 1 else f"{v:.4g}"


def summary(values: Sequence[float], unit: str = "", seeds: str = "") -> str:
    """``median (range lo-hi over n seeds)`` of ``values``."""
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


def config_raw(config: str) -> dict[str, Any]:
    """The YAML mapping of ``configs/papers/<config>``."""
    return yaml.safe_load((PAPERS / config).read_text())


def objective_from(raw: dict[str, Any], config: str = "<papers>"):
    """Objective of a config mapping, evaluated serially in this process."""
    from tuner.config import config_from_dict
    from tuner.run import _build

    raw = {**raw, "parallel": {"backend": "serial", "n_jobs": 1}}
    objective, _ = _build(config_from_dict(raw, source=config, base_dir=PAPERS))
    return objective


def default_score(config: str, which: str = "test", sets: Sequence[str] = ()) -> float:
    """Fitness of a paper config's default parameters (the paper's values) on one split."""
    from tuner.config import load_config
    from tuner.run import _build

    objective, _ = _build(load_config(PAPERS / config, list(sets), n_jobs=1))
    params = objective.default_params()
    if not hasattr(objective, "score"):  # single-scenario objectives (closed loop): the evaluation itself
        ev = objective(params)
        if ev.status != "ok":
            raise ValueError(f"{config}: defaults could not be evaluated: {ev.error}")
        return float(ev.fitness)
    score = objective.score(params, which)
    if not score.ok:
        raise ValueError(f"{config}: defaults could not be scored on {which!r}: {score.failed}")
    return float(score.fitness)


def tuned(config: str, population: int | None, generations: int | None, out: Path, sets: Sequence[str] = (),
          tag: str = "", max_evals: int | None = None, seed: int | None = None, light: bool = False) -> dict:
    """Run ``config`` (in this process) into ``out/<stem><tag>[-s<seed>]`` at a PSO budget (``population`` x
    ``generations``) or, with ``max_evals``, at that many evaluations of the config's own method (plus
    ``--set`` overrides ``sets``, and ``seed`` for the run seed); return its best.yaml (empty ``params``,
    ``metrics`` and ``evaluation`` when no evaluation succeeded). ``light``: in this process instead of the
    config's workers (the same results) and without the run's final report, which no row reads."""
    import shutil

    from tuner.config import load_config
    from tuner.run import run

    run_dir = out / (Path(config).stem + tag + (f"-s{seed}" if seed is not None else ""))
    if run_dir.exists():  # runs/papers/ belongs to this script: each call measures afresh
        shutil.rmtree(run_dir)
    over = [f"optimizer.max_evals={max_evals}"] if max_evals is not None else [
        f"optimizer.population={population}", f"optimizer.generations={generations}"]
    cfg = load_config(PAPERS / config, over + list(sets), seed=seed, n_jobs=1 if light else None)
    run(cfg, run_dir, quiet=True, report=not light)
    best = run_dir / "best.yaml"
    if not best.exists():  # no evaluation succeeded (e.g. none met a closed loop's requirements)
        return {"params": {}, "metrics": {}, "evaluation": {}}
    return yaml.safe_load(best.read_text())


def tune_cmd(config: str, budget: str, sets: Sequence[str] = ()) -> str:
    """The command line of a tuning row (``<seed>`` stands for each seed)."""
    s = "".join(f" --set '{kv}'" if " " in kv else f" --set {kv}" for kv in sets)
    return f"python -m tuner run configs/papers/{config} {budget}{s} --seed <seed>"
