"""How much a tuning result depends on its seed: the spread over a repeated run's seeds, the repeat to deploy,
the warning.

A job with ``repeats: N`` (``tuner run --repeats N``; driven by :mod:`tuner.repeats`) is N ordinary runs whose
seeds follow :data:`SEED_RULE`. This module computes, from what each repeat recorded (a
:class:`tuner.records.RepeatEntry`), the :class:`tuner.records.Repeats` record of ``repeats.json``; it touches no
file. Its three rules, each stated in what it writes:

- **Statistics** (:func:`spread_of`): median, lowest and highest over the repeats that have a best, of the best
  fitness, of each searched parameter's best value (with the share of its search range the repeats span,
  measured in log10 for a log-scaled parameter) and of the held-out score.
- **The result to deploy** (:func:`choose`, :data:`CHOICE_RULES`): when every repeat with a best has a
  held-out score (:func:`held_out_score`: the job's ``test:`` data, else the held-out fold of
  ``validation.select``), the repeat with the lowest one; its held-out score is then optimistic, since it
  chose. Otherwise the repeat of median best fitness: rank ``n // 2`` (from 0) of the ``n`` repeats with a
  best sorted by best fitness (then by index): the median for odd ``n``, the worse of the two middle ones for
  even ``n``, never the luckiest of two or more. Choosing the luckiest would report the seed's luck as the
  tuning's merit.
- **The warning** (:func:`spread_warning`, :data:`WARN_RULE`): when the spread of the best fitness (highest
  minus lowest) exceeds :data:`SPREAD_WARN` times the gain of tuning (the defaults' fitness minus the median
  best fitness), or when the median is no better than the defaults; without a defaults score there is nothing
  to compare the spread with, and the record says so.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

from tuner.records import RepeatEntry, Repeats, Spread

__all__ = ["SEED_RULE", "SPREAD_WARN", "WARN_RULE", "CHOICE_RULES", "repeat_seeds", "held_out_score", "spread_of",
           "choose", "spread_warning", "summarize", "spread_lines", "spread_md", "fmt"]

#: how a repeated run's seeds follow from the job's seed (repeat i of a job with seed s is the run of seed s + i)
SEED_RULE = "seed + i for repeat i = 0 .. N - 1 (repeat i is the run `tuner run JOB --seed <seed + i>`)"
#: the spread of the best fitness over seeds is large above this share of the gain of tuning over the defaults
SPREAD_WARN = 0.25
WARN_RULE = (f"warn when the spread of the best fitness over the seeds (highest - lowest) exceeds {SPREAD_WARN:g} x "
             "the gain of tuning (defaults' fitness - median best fitness), or when the median is no better than "
             "the defaults")
#: the choice rule in words, by ``Repeats.chosen_by``
CHOICE_RULES = {
    "held_out": "the repeat with the lowest held-out score ({key}); that score is optimistic, since it chose",
    "median_fitness": "the repeat of median best fitness (rank n // 2 from the best of the n repeats with a best: "
                      "the median for odd n, the worse of the two middle ones for even n; never the luckiest)",
}
#: ``held_out_key`` in words
HELD_OUT_NAMES = {"test_fitness": "test score: the job's test data", "selection": "the held-out fold of "
                  "validation.select"}


def repeat_seeds(seed: int, n: int) -> list[int]:
    """The seeds of the ``n`` repeats of a job with seed ``seed`` (:data:`SEED_RULE`)."""
    return [int(seed) + i for i in range(int(n))]


def _finite(v: Any) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


def held_out_score(evaluation: Mapping[str, Any]) -> tuple[str, float] | None:
    """``(key, score)`` of a run's best on data its tuning did not see, from ``best.yaml``'s ``evaluation``:
    ``test_fitness`` (the objective's score on the job's test data), else ``selection`` (the score on the
    held-out fold of ``validation.select`` of the candidate that fold chose); None without either. A failed
    score (inf) is a score."""
    test = evaluation.get("test_fitness")
    if isinstance(test, (int, float)) and not isinstance(test, bool) and not math.isnan(test):
        return "test_fitness", float(test)
    sel = evaluation.get("selection")
    if not isinstance(sel, Mapping) or not sel.get("candidates"):
        return None
    if sel.get("defaults_chosen"):
        d = sel.get("defaults") or {}
        v = d.get("holdout_fitness")
    else:
        v = next((c.get("holdout_fitness") for c in sel["candidates"] if c.get("eval") == sel.get("chosen_eval")), None)
    return ("selection", float(v)) if isinstance(v, (int, float)) and not isinstance(v, bool) else None


def _median(values: Sequence[float]) -> float:
    v = sorted(values)
    n = len(v)
    return v[n // 2] if n % 2 else 0.5 * (v[n // 2 - 1] + v[n // 2])


def spread_of(values: Sequence[float], unit: Any = None) -> Spread | None:
    """Median, lowest and highest of ``values`` (None when empty); ``unit(v)`` maps a value into its search
    range's unit interval (:meth:`tuner.space.Real.to_unit`) for ``range_share``."""
    vals = [float(v) for v in values if isinstance(v, (int, float)) and not isinstance(v, bool) and not math.isnan(v)]
    if not vals:
        return None
    lo, hi = min(vals), max(vals)
    share = None
    if unit is not None and math.isfinite(lo) and math.isfinite(hi):
        share = abs(float(unit(hi)) - float(unit(lo)))
    return Spread(_median(vals), lo, hi, len(vals), share)


def choose(entries: Sequence[RepeatEntry]) -> tuple[int | None, str, str]:
    """``(index, chosen_by, held_out_key)``: the repeat whose best is deployed (:data:`CHOICE_RULES`); ``(None,
    "", "")`` when no repeat has a best."""
    have = [e for e in entries if e.fitness is not None and not math.isnan(e.fitness)]
    if not have:
        return None, "", ""
    keys = {e.held_out_key for e in have}
    if len(keys) == 1 and "" not in keys and all(e.held_out is not None for e in have):
        e = min(have, key=lambda x: (x.held_out, x.fitness, x.index))
        return e.index, "held_out", keys.pop()
    ranked = sorted(have, key=lambda x: (x.fitness, x.index))
    return ranked[len(ranked) // 2].index, "median_fitness", ""


def spread_warning(fitness: Spread | None, defaults: float | None) -> tuple[float | None, str]:
    """``(gain, warning)``: the gain of tuning (defaults minus the median best fitness; None without both) and
    the warning by :data:`WARN_RULE` ('' when there is none)."""
    if fitness is None or fitness.n < 2:
        return None, ""
    if defaults is None or not math.isfinite(defaults) or not math.isfinite(fitness.median):
        return None, ""
    gain = defaults - fitness.median
    if gain <= 0:
        return gain, (f"the median best fitness over {fitness.n} seeds ({fmt(fitness.median)}) is no better than "
                      f"the defaults' ({fmt(defaults)}): tuning did not pay on this job")
    if fitness.width > SPREAD_WARN * gain:
        return gain, (f"the best fitness spreads over {fmt(fitness.width)} between seeds ({fmt(fitness.low)} .. "
                      f"{fmt(fitness.high)}), {fitness.width / gain:.0%} of the gain of tuning ({fmt(gain)} = defaults "
                      f"{fmt(defaults)} - median {fmt(fitness.median)}): which seed ran matters about as much as "
                      "tuning; give the optimiser more evaluations or deploy with care")
    return gain, ""


def summarize(seeds: Sequence[int], entries: Sequence[RepeatEntry], space: Any = None) -> Repeats:
    """The :class:`tuner.records.Repeats` record of ``entries`` (one per seed, in seed order): spread, choice and
    warning by the module's rules; ``space`` (the run's :class:`tuner.space.Space`) gives the searched
    parameters and their ranges. A repeat is chosen only when every repeat finished."""
    have = [e for e in entries if e.fitness is not None and not math.isnan(e.fitness)]
    complete = bool(entries) and all(e.status == "finished" for e in entries)
    fitness = spread_of([e.fitness for e in have])  # type: ignore[misc]
    names = [p.name for p in space.free] if space is not None else sorted({k for e in have for k in e.params})
    params = {}
    for name in names:
        vals = [e.params[name] for e in have if _finite(e.params.get(name))]
        unit = space[name].to_unit if space is not None and name in space else None
        if (s := spread_of(vals, unit)) is not None:
            params[name] = s
    chosen, by, key = choose(have) if complete else (None, "", "")
    if not key:
        keys = {e.held_out_key for e in have}
        key = keys.pop() if len(keys) == 1 else ""
    held = spread_of([e.held_out for e in have if e.held_out is not None and e.held_out_key == key]) if key else None
    dflt = spread_of([e.defaults_fitness for e in have if e.defaults_fitness is not None])
    defaults = dflt.median if dflt is not None else None
    gain, warning = spread_warning(fitness, defaults)
    rule = CHOICE_RULES[by].format(key=HELD_OUT_NAMES.get(key, key)) if by else ""
    return Repeats(tuple(int(s) for s in seeds), tuple(entries), complete, fitness, params, key, held, chosen, by,
                   rule, defaults, gain, warning,
                   WARN_RULE if defaults is not None else "no defaults' fitness: the spread is not compared with a "
                   "gain of tuning")


def fmt(v: Any) -> str:
    """A number as the spread lines print it (4 significant digits; '-' for None)."""
    if v is None:
        return "-"
    if isinstance(v, float):
        return "nan" if math.isnan(v) else f"{v:.4g}"
    return str(v)


def spread_lines(rep: Repeats) -> list[str]:
    """The spread of a repeated run for the terminal (``tuner run``, ``resume``, ``show``): one line per repeat,
    then the statistics, the chosen repeat and the warning."""
    done = sum(e.status == "finished" for e in rep.entries)
    seeds = ", ".join(str(s) for s in rep.seeds) if rep.n <= 8 else f"{rep.seeds[0]} .. {rep.seeds[-1]}"
    out = [f"repeats:    {rep.n} seeds ({seeds}: seed + 0 .. {rep.n - 1}), {done} finished"]
    held = rep.held_out_key
    head = f"  {'seed':>6}  {'status':11s}  {'best fitness':>12}" + (f"  {held:>12}" if held else "")
    out.append(head)
    for e in rep.entries:
        mark = "  <- chosen" if rep.chosen == e.index else ""
        out.append(f"  {e.seed:>6}  {e.status:11s}  {fmt(e.fitness):>12}"
                   + (f"  {fmt(e.held_out):>12}" if held else "") + mark)
    if rep.fitness is not None:
        f = rep.fitness
        out.append(f"fitness:    median {fmt(f.median)} over {f.n} seeds, {fmt(f.low)} .. {fmt(f.high)} "
                   f"(spread {fmt(f.width)})" + (f"; defaults {fmt(rep.defaults_fitness)}"
                                                 if rep.defaults_fitness is not None else ""))
    if rep.held_out is not None:
        h = rep.held_out
        out.append(f"held out:   median {fmt(h.median)}, {fmt(h.low)} .. {fmt(h.high)} ({held})")
    if rep.params:
        width = max(len(k) for k in rep.params)
        out.append("parameters: median, lowest .. highest over the seeds (share of the search range they span)")
        for k, s in rep.params.items():
            share = f" ({s.range_share:.0%})" if s.range_share is not None else ""
            out.append(f"  {k:{width}s}  {fmt(s.median)}, {fmt(s.low)} .. {fmt(s.high)}{share}")
    if rep.chosen_entry is not None:
        c = rep.chosen_entry
        out.append(f"chosen:     seed {c.seed} ({c.run}): {rep.rule}")
    elif not rep.complete:
        out.append("chosen:     none yet (a repeat is chosen when every repeat has finished)")
    if rep.warning:
        out.append(f"warning: {rep.warning} (rule: {rep.warn_rule})")
    return out


def spread_md(rep: Repeats) -> list[str]:
    """The report's section on a repeated run: one row per seed, the spread of the fitness and of each searched
    parameter, the chosen repeat and its rule, and the warning."""
    from tuner.render import md_escape

    held = rep.held_out_key
    md = ["## Repeats", "", f"{rep.n} runs of this job, seeds {SEED_RULE}.", ""]
    md += ["| seed | status | best fitness |" + (f" {held} |" if held else "") + " run |",
           "|---|---|---|" + ("---|" if held else "") + "---|"]
    for e in rep.entries:
        mark = " **(deployed)**" if rep.chosen == e.index else ""
        md.append(f"| {e.seed} | {e.status} | {fmt(e.fitness)} |" + (f" {fmt(e.held_out)} |" if held else "")
                  + f" [{e.run}]({e.run}/){mark} |")
    md += ["", "| quantity | median | lowest | highest | share of search range |", "|---|---|---|---|---|"]
    if rep.fitness is not None:
        f = rep.fitness
        md.append(f"| best fitness | {fmt(f.median)} | {fmt(f.low)} | {fmt(f.high)} | |")
    if rep.held_out is not None:
        h = rep.held_out
        md.append(f"| {held} | {fmt(h.median)} | {fmt(h.low)} | {fmt(h.high)} | |")
    for k, s in rep.params.items():
        share = f"{s.range_share:.0%}" if s.range_share is not None else ""
        md.append(f"| {md_escape(k)} | {fmt(s.median)} | {fmt(s.low)} | {fmt(s.high)} | {share} |")
    md.append("")
    if rep.chosen_entry is not None:
        md += [f"Deployed: seed {rep.chosen_entry.seed}, {md_escape(rep.rule)}.", ""]
    else:
        md += ["Deployed: none yet (a repeat is chosen when every repeat has finished).", ""]
    if rep.defaults_fitness is not None:
        md += [f"Defaults' fitness {fmt(rep.defaults_fitness)}; gain of tuning {fmt(rep.gain)}.", ""]
    if rep.warning:
        md += [f"**Warning:** {md_escape(rep.warning)} (rule: {md_escape(rep.warn_rule)}).", ""]
    return md
