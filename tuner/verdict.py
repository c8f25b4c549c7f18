"""Whether tuning helped: the one line a run's result carries when held-out or CV scores say the tuned
values are worse than the objective's defaults.

A tuning score is measured on the data the search looked at, so it always favours the tuned values; only
scores on data the search did not see can say the tuning made things worse. Two such comparisons exist in a
run's ``best.yaml`` evaluation (:mod:`tuner.validation`): ``test_fitness`` against ``defaults_test_fitness``
(held-out recordings) and ``cv_fitness`` against ``defaults_cv_fitness`` (the same folds for both). When the
tuned side is worse in either, the run says so in one line, in the terminal at its end, ``tuner show``, the
report's warnings, the dashboard and ``tuner export``; the line also says what is deployed: the defaults, when
the held-out selection (``validation: {select: ...}``, which includes the defaults by default) or the run's
cross-validation (``cv_deploys_defaults``) chose them, else the tuned values. Lower is better, as everywhere
in the engine. Imports nothing, so every reader can use it.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

__all__ = ["defaults_verdict", "optimistic_note", "transfer_line"]

#: (tuned key, defaults key, what the scores are)
_PAIRS = (("test_fitness", "defaults_test_fitness", "held-out"), ("cv_fitness", "defaults_cv_fitness", "CV"))


def _num(v: Any) -> float | None:
    try:
        x = float(v)
    except (TypeError, ValueError):
        return None
    return x if math.isfinite(x) else None


def defaults_verdict(evaluation: Mapping[str, Any] | None) -> str | None:
    """One line when held-out or CV scores in ``evaluation`` (a ``best.yaml`` evaluation) are worse for the
    tuned values than for the defaults, or when the held-out selection chose the defaults (the deployed values
    then are the defaults, so the tuned-vs-defaults scores agree, but the run must say tuning did not help);
    else ``None``."""
    if not evaluation:
        return None
    worse = []
    for tuned_key, dflt_key, what in _PAIRS:
        t, d = _num(evaluation.get(tuned_key)), _num(evaluation.get(dflt_key))
        if t is not None and d is not None and t > d:
            worse.append(f"{what} {t:.4g} vs defaults {d:.4g}")
    sel = evaluation.get("selection")
    chosen = isinstance(sel, Mapping) and bool(sel.get("defaults_chosen"))
    by_cv = bool(evaluation.get("cv_deploys_defaults"))
    if not worse:
        return _defaults_chosen_line(sel) if chosen else None
    deployed = ("the run deploys the defaults (the held-out selection chose them)" if chosen else
                "the run deploys the defaults (the cross-validation chose them)" if by_cv else
                "best.yaml holds the tuned values; `validation: {select: {}}` deploys the defaults when they "
                "score better held out")
    return f"tuned is worse than the defaults on data the search did not see ({'; '.join(worse)}): {deployed}"


def _defaults_chosen_line(sel: Mapping[str, Any]) -> str:
    """The line of a held-out selection that chose the defaults: tuning did not help on the held-out fold."""
    held = [_num(c.get("holdout_fitness")) for c in sel.get("candidates") or []]
    held = [h for h in held if h is not None]
    d = _num((sel.get("defaults") or {}).get("holdout_fitness"))
    nums = (f" ({d:.4g} vs best tuned {min(held):.4g})" if d is not None and held else "")
    return (f"tuning does not help on the held-out fold {sel.get('holdout')}{nums}: the run deploys the defaults "
            "(the held-out selection chose them)")


def optimistic_note(chosen_on: Any) -> str | None:
    """The report's note for a config whose fixed choices (options, search ranges) were made by looking at the
    same data (the objective's ``chosen_on:`` declaration, a text saying on what): its CV, which re-tunes only the
    searched values in each fold, is optimistic."""
    if not chosen_on:
        return None
    return (f"the config's fixed options and search ranges were chosen on {chosen_on}, outside this run's "
            "validation: its CV re-tunes only the searched values per fold, so the CV score is optimistic "
            "for data those choices never saw")


def transfer_line(validation: Mapping[str, Any] | None) -> str:
    """One line of a leave-one-dataset-out CV's transfer table (``validation.json``'s ``cv.transfer``): each
    dataset's tuned - defaults difference (negative: tuning on the other datasets carries over), or ``""``."""
    rows = ((validation or {}).get("cv") or {}).get("transfer") or []
    parts = []
    for r in rows:
        d = _num(r.get("difference"))
        parts.append(f"{r.get('dataset')} {'-' if d is None else f'{d:+.4g}'}")
    return ("transfer (tuned on the other datasets - defaults): " + ", ".join(parts)) if parts else ""
