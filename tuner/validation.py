"""A run's ``validation:`` section: cross-validation after the run and the final choice by a held-out fold.

Tuning minimises the error on the data it sees; users meet other data. Two documented options of a
job (:class:`tuner.config.ValidationConfig`) measure and act on that, both through the objective's
``cv_folds`` hook (the engine does not know what a fold is):

``validation: {cv: logo | kfold, folds: k, budget_fraction: f, gap_warn_rel: 0.25, gap_warn_abs: x}``
    After the run, :func:`tuner.cv.cross_validate` tunes on every fold's complement (``f`` times the
    run's generations) and scores the held-out fold; the run's own best parameters, scored on every
    held-out fold the same way, give the *tuning score*. The gap is ``CV score - tuning score``; it is
    *large* above ``gap_warn_rel`` times the tuning score or above ``gap_warn_abs`` (fitness units).
    ``cv.md``, ``cv.csv`` and ``validation.json`` go into the run directory (:mod:`tuner.rundir`), the
    numbers into ``best.yaml``'s ``evaluation`` (``tuning_score``, ``cv_fitness``, ``cv_gap``,
    ``cv_gap_large``, ``defaults_cv_fitness``), which the run report and sweep reports show. Folds hold the
    tuning recordings only; ``test:`` recordings keep their own score (``test_score``,
    ``defaults_test_score`` in ``validation.json``).

Every finished run also records its defaults (:func:`tuner.deployment.defaults_baseline`) scored as its best is
(:func:`defaults_scores`: ``defaults_fitness``, ``defaults_train_fitness``, ``defaults_test_fitness``),
which sweeps show as each method's defaults row. ``tuner cv RUN_DIR`` does the
    same for a finished run.

``validation: {select: {top_k: 5, holdout: NAME | fraction}}``
    The run tunes on all recordings but the held-out fold (a fold name of ``cv_folds()``, e.g. a BROAD
    group, or fraction ``h``: fold 0 of ``cv_folds(round(1 / h))``). After the run the ``top_k`` best
    distinct candidates of ``history.csv`` are scored on the held-out fold (the objective's plain
    ``score``: no prior, no aggregation options) and the best there becomes ``best.yaml``, which keeps
    its tuning fitness and records both numbers of every candidate under ``evaluation.selection``.
    With ``include_defaults: true`` (the default) the objective's defaults of the searched parameters
    (``default_params`` hook; a default outside the search bounds is scored as it is and named under
    ``outside_bounds``) are one more candidate; ``defaults_chosen`` says when they won (strictly lower
    held-out score than every tuned candidate); ``best.yaml`` then holds the defaults with their tuning
    fitness and ``found.eval = -1`` (no evaluation of the history).

When the cross-validation says the procedure scores worse on the held-out folds than the defaults on the same
folds, the run deploys the defaults (:func:`cv_deploys_defaults`; the defaults are a candidate unless
``select: {include_defaults: false}``): ``best.yaml`` then holds them, with ``cv_deploys_defaults: true``, and
the run says so in one line (:mod:`tuner.verdict`).

Cross-validation with ``select`` (:func:`tuner.cv.cross_validate`) repeats the whole procedure in every
fold: the fold's tuning recordings are split again by :func:`inner_split` (the named fold when the fold's
recordings hold it, else the fraction: ``holdout`` if a number, else :data:`FALLBACK_FRACTION`), tuned on
the rest, and the candidates (and the defaults) chosen among on the inner held-out part
(:func:`tune_and_select`), so the CV score measures what a run delivers.
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from tuner.config import ConfigError, RunConfig
from tuner.cv import cross_validate, cv_texts, transfer_rows
from tuner.objective import hook
from tuner.records import Best, RunError, plain
from tuner.rundir import RunDir
from tuner.selection import (  # re-exported: the selection procedure's home is tuner.selection
    FALLBACK_FRACTION,
    defaults_candidate,
    inner_split,
    scored,
    select_best,
    selection_split,
    tune_and_select,
    tuning_objective,
)
from tuner.setup import run_config

__all__ = ["selection_split", "tuning_objective", "select_best", "validate_run", "cv_run_dir", "inner_split",
           "cv_deploys_defaults",
           "defaults_candidate", "tune_and_select", "defaults_scores", "FALLBACK_FRACTION"]

def _cv(cfg: RunConfig, rd: RunDir, params: dict[str, Any], progress: Callable[[str], None] | None,
        k: int | None = None) -> dict[str, Any]:
    """Cross-validate ``cfg`` with ``params`` as the tuning result; write the tables; return the summary."""
    v = cfg.validation
    if k is None:
        kind = v.cv or "logo"
        k = v.folds if kind == "kfold" else None
    else:  # an explicit number of folds (tuner cv RUN_DIR --k K) wins over the config's
        kind = "kfold"
    t0 = time.time()
    out = cross_validate(cfg, k=k, progress=progress, budget_fraction=v.budget_fraction, full_params=params)
    md, table = cv_texts(out, v)
    rd.write_cv_tables(md, table)
    s = out.summary()
    doc = {"kind": kind, "folds": len(out.folds), "budget_fraction": v.budget_fraction,
           "tuning_score": s.get("tuning_score"), "cv_score": s["cv_mean"], "gap": s.get("gap"),
           "gap_large": v.gap_is_large(s.get("gap", math.nan), s.get("tuning_score", math.nan)),
           "gap_rule": v.gap_rule(), "defaults_cv_score": s["defaults_mean"], "cv_fold_std": s["cv_fold_std"],
           "cv_fold_worst": s["cv_fold_worst"], "seconds": round(time.time() - t0, 1),
           "per_fold": {f.name: f.cv_fitness for f in out.folds},
           "per_fold_recordings": {f.name: list(f.recordings) for f in out.folds}}
    if out.by:  # leave one dataset out: the transfer table (each dataset: defaults, tuned, difference)
        doc["transfer"] = transfer_rows(out)
    if out.test:  # the job's test: recordings, never in a fold, keep their own held-out score
        doc.update(test_score=out.test["tuned"], defaults_test_score=out.test["defaults"],
                   test_recordings=out.test["recordings"])
    if any(f.selection for f in out.folds):  # which candidate each fold's inner selection chose
        doc["per_fold_selection"] = {f.name: f.selection for f in out.folds}
    return plain(doc)


def _record(rd: RunDir, best: Best, cv: dict[str, Any] | None, selection: dict[str, Any] | None,
            write_best: bool = True) -> Best:
    """``best`` with the selection and CV scores in its evaluation, and ``validation.json`` written; with
    ``write_best`` (``tuner cv RUN_DIR``) ``best.yaml`` too (a run's finish writes it itself, once)."""
    ev = dict(best.evaluation)
    doc: dict[str, Any] = {}
    try:
        doc = rd.validation() or {}
    except RunError:
        doc = {}
    if selection:
        ev["selection"] = selection
        doc["selection"] = selection
    if cv:
        ev.update(tuning_score=cv["tuning_score"], cv_fitness=cv["cv_score"], cv_gap=cv["gap"],
                  cv_gap_large=cv["gap_large"], defaults_cv_fitness=cv["defaults_cv_score"])
        doc["cv"] = cv
    best = dataclasses.replace(best, evaluation=plain(ev))
    if write_best:
        rd.write_best(best)
    if doc:
        rd.write_validation(doc)
    return best


def defaults_scores(cfg: RunConfig, objective: Any, space: Any = None) -> dict[str, Any]:
    """The defaults (:func:`tuner.deployment.defaults_baseline`) scored as a run's best is: ``defaults_fitness`` (the
    tuning fitness, as ``best_fitness``), ``defaults_train_fitness`` and ``defaults_test_fitness`` (the
    objective's plain ``score`` on its train and test data, as ``train_fitness``/``test_fitness``) where
    the objective has them. A defaults evaluation that fails, raises or times out scores inf."""
    from tuner.deployment import defaults_baseline

    try:
        params = defaults_baseline(objective, space if space is not None else cfg.space(objective))
    except ConfigError:  # no search space of its own to take the fixed values from: no defaults row
        return {}
    if params is None:
        return {}
    from tuner.evaluate import evaluate_one

    ev = evaluate_one(objective, params).evaluation  # as the preflight scores the defaults (timeout, failures)
    out: dict[str, Any] = {"defaults_fitness": float(ev.fitness) if ev.status == "ok" else math.inf}
    if hook(objective, "score") is not None:
        has_test = hook(objective, "has_test_data")
        for which in ("train", "test") if has_test is not None and has_test() else ("train",):
            try:
                fit, failed, _ = scored(objective, params, which)
            except Exception:  # noqa: BLE001 - as above
                fit, failed = math.inf, "raised"
            out[f"defaults_{which}_fitness"] = math.inf if failed or not math.isfinite(fit) else fit
    return out


def validate_run(cfg: RunConfig, rd: RunDir, best: Best, selection: dict[str, Any] | None,
                 progress: Callable[[str], None] | None = None, objective: Any = None, space: Any = None) -> Best:
    """After a run (its objective's report step done): the defaults' scores (with ``objective``, the run's
    own, and its search ``space``), the selection, the CV if configured. Returns ``best`` with their results
    in its evaluation; the run's finish writes it to ``best.yaml``."""
    if objective is not None:
        dflt = defaults_scores(cfg, objective, space)
        best = dataclasses.replace(best, evaluation=plain({**best.evaluation, **dflt}))
        if not cfg.validation.active:
            return best
    cv = None
    if cfg.validation.cv is not None:
        if progress:
            progress(f"validation: {cfg.validation.cv} cross-validation of the job")
        try:
            cv = _cv(cfg, rd, dict(best.params), progress)
        except ConfigError as exc:  # a finished run is kept; the report says why there is no CV
            if progress:
                progress(f"warning: cross-validation not run: {exc}")
            cv = {"error": str(exc)}
            rd.write_validation({"cv": cv, **({"selection": selection} if selection else {})})
            return _record(rd, best, None, selection, write_best=False)
    return _record(rd, best, cv, selection, write_best=False)


def cv_deploys_defaults(cfg: RunConfig, best: Best, objective: Any, space: Any) -> Best | None:
    """The defaults as the run's :class:`Best` when its cross-validation says the tuning procedure scores worse on
    the held-out folds than the defaults on the same folds (``cv_fitness > defaults_cv_fitness``, both finite),
    else None. The defaults are a candidate as in the held-out selection (``select.include_defaults``, on by
    default and without a ``select`` block); when that selection chose them already there is nothing to change.
    The returned record holds the defaults with their tuning fitness (``defaults_fitness``), ``found.eval = -1``
    and ``cv_deploys_defaults: true`` in its evaluation (the run's finish makes their deployment and report)."""
    sel = cfg.validation.select
    if cfg.validation.cv is None or (sel is not None and not sel.include_defaults):
        return None
    ev = best.evaluation
    cv_fit, dflt_fit = ev.get("cv_fitness"), ev.get("defaults_cv_fitness")
    if not all(isinstance(x, (int, float)) and math.isfinite(x) for x in (cv_fit, dflt_fit)) or cv_fit <= dflt_fit:
        return None
    if isinstance(ev.get("selection"), dict) and ev["selection"].get("defaults_chosen"):
        return None
    dflt = defaults_candidate(objective, space if space is not None else cfg.space(objective))
    fit = ev.get("defaults_fitness")
    if dflt is None or not isinstance(fit, (int, float)) or not math.isfinite(fit):
        return None
    return Best({**best.params, **dflt[0]}, float(fit), {}, -1, -1, -1, best.run,
                plain({**ev, "cv_deploys_defaults": True}))


def cv_run_dir(run_dir: str | Path, k: int | None = None, progress: Callable[[str], None] | None = None,
               budget_fraction: float | None = None) -> dict[str, Any]:
    """``tuner cv RUN_DIR``: cross-validate a finished run with its own config; its best is the tuning result.

    Writes ``cv.md``, ``cv.csv``, ``validation.json``, adds the scores to ``best.yaml`` and rewrites the
    report. Returns the CV summary of ``validation.json``.
    """
    from tuner.report import write_run_report

    rd = RunDir(run_dir)
    with rd.lock():
        meta = rd.meta()
        if meta.status != "finished":
            raise RunError(f"{rd.path}: status {meta.status!r}; cross-validate a finished run (or a config file)")
        cfg = run_config(rd)
        if budget_fraction is not None:
            cfg = dataclasses.replace(cfg, validation=dataclasses.replace(cfg.validation,
                                                                          budget_fraction=budget_fraction))
        best = rd.best()
        cv = _cv(cfg, rd, dict(best.params), progress, k)
        _record(rd, best, cv, None)
        write_run_report(rd.path)
    return cv
