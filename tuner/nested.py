"""Nested cross-validation of a config's fixed choices: the inner loop chooses, the outer loop scores.

A config's fixed options (e.g. a filter's ``variant`` or ``mag_rejection``) chosen by looking at the same data
its CV scores make that CV optimistic: the choice saw every held-out fold. ``validation: {cv: {by: logo,
nested: {choose: {variant: [paper, fast], rest_bias: [true, false]}}}}`` puts the choice inside the
validation. In every outer fold (:func:`tuner.cv.cross_validate`) the fold's tuning recordings are split again
(:func:`tuner.selection.inner_split`: the ``validation.select`` rule, else a quarter of them held out); each
combination of the candidate values is tuned on the inner tuning side (the config's procedure, with its
selection) and scored on the inner held-out side; the best combination is then tuned on all the fold's tuning
recordings and scored on the outer held-out fold, which no choice saw. The tuning on all data chooses the
same way, so the run's deployable choice comes from the same procedure the CV measured.

The engine does not know what an option is: a candidate value is written into the job's ``parameters`` as
``{fixed: value}``, as a config would write it (:class:`tuner.config.RunConfig`).
"""

from __future__ import annotations

import dataclasses
import itertools
import math
from collections.abc import Callable, Mapping
from typing import Any

from tuner.config import RunConfig, SelectConfig
from tuner.selection import inner_split, plain_score

__all__ = ["variants", "choose"]


def variants(cfg: RunConfig, objective: Any, choose: Mapping[str, tuple]) -> list[tuple[dict[str, Any], RunConfig]]:
    """``[(choice, cfg with those values fixed)]`` for every combination of ``choose``'s candidate values, in
    the order written (the first value of each option first)."""
    base = (dict(cfg.parameters) if cfg.parameters is not None
            else {p.name: p.to_dict() for p in cfg.space(objective).params})
    out = []
    for combo in itertools.product(*choose.values()):
        choice = dict(zip(choose, combo))
        params = {**base, **{k: {"fixed": v} for k, v in choice.items()}}
        out.append((choice, dataclasses.replace(cfg, parameters=params)))
    return out


def choose(cfg: RunConfig, objective: Any, procedure: Callable[[RunConfig, Any], tuple[dict, float, dict]],
           say: Callable[[str], None] = lambda m: None) -> tuple[dict[str, Any], RunConfig, dict[str, Any]]:
    """The inner loop on ``objective`` (one outer fold's tuning side, or all data): ``(choice, its cfg, record)``.

    ``procedure(cfg, objective) -> (params, tuning fitness, selection)`` tunes as a run does. The record is
    ``{holdout, choices: [{choice, inner_fitness}], chosen}``; ties keep the first combination written. A
    combination whose tuning fails scores inf.
    """
    v = cfg.validation
    name, inner_train, inner_test = inner_split(v.select or SelectConfig(), objective, cfg.source)
    rows = []
    for choice, vcfg in variants(cfg, objective, v.nested):
        params, _, _ = procedure(vcfg, inner_train)
        fit = plain_score(inner_test, params)[0] if params else math.inf
        rows.append({"choice": choice, "inner_fitness": fit if math.isfinite(fit) else math.inf})
        say(f"  inner fold {name}: {choice} -> {fit:.4g}")
    i = min(range(len(rows)), key=lambda j: (rows[j]["inner_fitness"], j))
    chosen = rows[i]["choice"]
    return chosen, variants(cfg, objective, {k: (val,) for k, val in chosen.items()})[0][1], \
        {"holdout": name, "choices": rows, "chosen": chosen}
