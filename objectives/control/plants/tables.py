"""The requirements table of a run: one row per requirement, scenario and model set, for people.

Columns: the requirement in words with its unit, the scenario, the model set (tuning set, held-out set),
the limit, the tuned value (the worst over the set's models), whether it is met (on every model of the
tuning set; the pass rate over the held-out models), the small-signal value and whether it is met (see
:mod:`.robustness`; ``(linear)`` for margins, which are small-signal by definition), and the same two
for the defaults. The same rows give the Markdown table of ``requirements.md`` and the report's lead, and
the aligned text the terminal prints after a run.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from objectives.control.plants.requirements import REQUIREMENTS, SS_TOLERANCE
from objectives.control.plants.robustness import Assessment, SetResult, saturation_only, worst

__all__ = ["requirement_rows", "markdown_table", "lead_table", "text_table", "HEAD", "saturation_notes",
           "heldout_summary"]

HEAD = ("requirement", "scenario", "models", "limit", "tuned", "met", "small-signal", "met", "defaults", "met")


def fmt(v: float) -> str:
    if v is None or (isinstance(v, float) and math.isnan(v)):
        return "-"
    if math.isinf(v):
        return "inf" if v > 0 else "-inf"
    return f"{v:.4g}"


def unit_words(unit: str) -> str:
    """A unit as a column heading shows it: the plant's own ``output``/``input`` units in words."""
    return f"{unit} units" if unit in ("output", "input") else unit


def _limit(loop: Any, key: str, s: int | None) -> str:
    r = REQUIREMENTS[key]
    unit = "" if r.unit in ("1", "output", "input") else f" {r.unit}"
    lim = loop.cases[s].limits[key] if s is not None else loop._margin_req[key]
    text = f"{'<=' if r.sense == 'max' else '>='} {lim:g}{unit}"
    if key == "max_ss_error" and lim == 0.0 and s is not None:
        text += f" (tolerance {SS_TOLERANCE:g} x step = {loop.cases[s].effective_limit(key):.3g})"
    return text


def _met(res: SetResult | None, key: str, s: int | None, rate: bool) -> tuple[str, str, bool | None]:
    """``(value, met text, met)`` of one check on one set result."""
    if res is None:
        return "-", "-", None
    if res.error:
        return "-", "NO (" + res.error.split(" at t=")[0].replace("closed loop ", "") + ")", False
    c = res.check(key, s)
    if c is None:
        return "-", "-", None
    met = np.asarray(c["met"])
    if rate:
        return fmt(worst(c)), f"{100.0 * met.mean():.1f} %", bool(met.all())
    if met.all():
        return fmt(worst(c)), "yes", True
    return fmt(worst(c)), "NO" if met.size == 1 else f"NO ({int((~met).sum())} of {met.size})", False


def requirement_rows(loop: Any, tuned: Assessment, defaults: Assessment) -> list[list[str]]:
    """The table's rows (:data:`HEAD`)."""
    rows = []
    single = len(loop.cases) == 1
    sat = {(d["key"], d["scenario"]) for d in saturation_only(tuned)}
    sets = [("tuning", tuned.tuning, defaults.tuning, False)]
    if tuned.heldout is not None:
        sets.append(("held-out", tuned.heldout, defaults.heldout, True))
    for key, s in loop.check_keys():
        r = REQUIREMENTS[key]
        words = r.words + ("" if r.unit == "1" else f" ({unit_words(r.unit)})")
        scen = "-" if s is None or single else loop.cases[s].name
        for name, t_res, d_res, rate in sets:
            tv, tm, _ = _met(t_res, key, s, rate)
            dv, dm, _ = _met(d_res, key, s, rate)
            if name != "tuning":
                sv, sm = "-", "-"
            elif r.scope == "margin":
                sv, sm = "(linear)", "-"
            elif tuned.small is None:
                sv, sm = "no limit", "-"
            else:
                sv, sm, _ = _met(tuned.small, key, s, False)
                if (key, s) in sat:
                    sm = "NO: met only through saturation"
            rows.append([words, scen, f"{name} ({t_res.n_models})", _limit(loop, key, s), tv, tm, sv, sm, dv, dm])
    return rows


def markdown_table(rows: list[list[str]]) -> str:
    """The rows as a Markdown table (``|`` in a cell escaped)."""
    def cell(x: str) -> str:
        return str(x).replace("|", "\\|")
    lines = ["| " + " | ".join(HEAD) + " |", "|" + "---|" * len(HEAD)]
    lines += ["| " + " | ".join(cell(c) for c in r) + " |" for r in rows]
    return "\n".join(lines) + "\n"


def lead_table(rows: list[list[str]]) -> str:
    """The rows as the report's lead shows them, narrow enough for a phone: the verdict right after the
    requirement (so it is on screen at 390 px), the tuned value, the limit, the small-signal value with its
    verdict, then the scenario and model set (the defaults are in ``requirements.md``)."""
    out = []
    for words, scen, models, limit, tv, tm, sv, sm, _dv, _dm in rows:
        where = ", ".join(x for x in (scen if scen != "-" else "", models) if x)
        small = sv if sm in ("-", "") else f"{sv}: {sm}"
        out.append([words, tm, tv, limit, small, where])
    head = ("requirement", "met", "tuned", "limit", "small signal", "scenario, models")
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    lines += ["| " + " | ".join(str(c).replace("|", "\\|") for c in r) + " |" for r in out]
    return "\n".join(lines) + "\n"


def text_table(rows: list[list[str]]) -> str:
    """The rows as aligned text (the terminal)."""
    table = [list(HEAD), *rows]
    widths = [max(len(str(r[i])) for r in table) for i in range(len(HEAD))]
    return "\n".join("  ".join(str(c).ljust(w) for c, w in zip(r, widths)).rstrip() for r in table)


def saturation_notes(loop: Any, tuned: Assessment) -> list[str]:
    """One sentence per requirement met only through saturation, with both numbers."""
    out = []
    for d in saturation_only(tuned):
        r = REQUIREMENTS[d["key"]]
        unit = "" if r.unit in ("1", "output", "input") else f" {r.unit}"
        scen = f" in scenario {loop.cases[d['scenario']].name}" if len(loop.cases) > 1 else ""
        out.append(f"{r.words}{scen} is met only through saturation: {fmt(d['tuned'])}{unit} in the tuning scenario, "
                   f"{fmt(d['small'])}{unit} small-signal (limit {_limit(loop, d['key'], d['scenario'])}); add a "
                   "scenario with a step small enough that nothing saturates to tune for both")
    return out


def heldout_summary(res: SetResult | None) -> dict[str, float]:
    """Pass rate of all requirements, worst margins and the per-model cost's distribution on a held-out set."""
    if res is None:
        return {}
    out = {"pass_rate": float(res.pass_all().mean()) if res.n_models else math.nan}
    if res.error:
        return out
    c = np.asarray(res.per_model, dtype=float)
    out.update({"cost_mean": float(c.mean()), "cost_median": float(np.median(c)),
                "cost_p95": float(np.percentile(c, 95)), "cost_max": float(c.max())})
    if res.margins:
        out.update({"ms_max": max(m["ms"] for m in res.margins), "gm_db_min": min(m["gm_db"] for m in res.margins),
                    "pm_deg_min": min(m["pm_deg"] for m in res.margins)})
    return out
