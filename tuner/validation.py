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
    ``cv_gap_large``), which the run report and sweep reports show. ``tuner cv RUN_DIR`` does the
    same for a finished run.

``validation: {select: {top_k: 5, holdout: NAME | fraction}}``
    The run tunes on all recordings but the held-out fold (a fold name of ``cv_folds()``, e.g. a BROAD
    group, or fraction ``h``: fold 0 of ``cv_folds(round(1 / h))``). After the run the ``top_k`` best
    distinct candidates of ``history.csv`` are scored on the held-out fold (the objective's plain
    ``score``: no prior, no aggregation options) and the best there becomes ``best.yaml``, which keeps
    its tuning fitness and records both numbers of every candidate under ``evaluation.selection``.
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from tuner.config import ConfigError, RunConfig, config_from_dict
from tuner.objective import hook
from tuner.rundir import FIXED_COLUMNS, RESULT_COLUMNS, Best, RunDir, RunError, parse_cell, plain

__all__ = ["selection_split", "tuning_objective", "select_best", "validate_run", "cv_run_dir"]


def _folds(cfg: RunConfig, objective: Any, k: int | None, key: str) -> list:
    fn = hook(objective, "cv_folds")
    if fn is None:
        raise ConfigError(cfg.source, key, f"{type(objective).__name__} has no cv_folds hook: no held-out folds")
    try:
        return list(fn(k))
    except ValueError as exc:
        raise ConfigError(cfg.source, key, str(exc)) from None


def selection_split(cfg: RunConfig, objective: Any) -> tuple[str, Any, Any]:
    """``(fold name, tuning objective, held-out objective)`` of ``validation.select.holdout``."""
    sel = cfg.validation.select
    assert sel is not None
    key = "validation.select.holdout"
    if isinstance(sel.holdout, str):
        folds = _folds(cfg, objective, None, key)
        match = [f for f in folds if str(f[0]) == sel.holdout]
        if not match:
            raise ConfigError(cfg.source, key, f"no fold named {sel.holdout!r}; the objective's folds are "
                              f"{[str(f[0]) for f in folds]}")
        return match[0][0], match[0][1], match[0][2]
    k = max(2, round(1.0 / sel.holdout))
    name, train, test = _folds(cfg, objective, k, key)[0]
    return str(name), train, test


def tuning_objective(cfg: RunConfig, objective: Any) -> Any:
    """The objective a run tunes: ``objective`` itself, or its tuning side when ``select`` holds a fold out."""
    if cfg.validation.select is None:
        return objective
    return selection_split(cfg, objective)[1]


def _candidates(rd: RunDir, names: list[str], top_k: int) -> list[tuple[dict[str, Any], float, dict[str, Any], dict]]:
    """The ``top_k`` best distinct successful rows of the history: (params, fitness, metrics, found)."""
    rows = []
    for r in rd.history_rows():
        if r.get("status") != "ok":
            continue
        fit = parse_cell(r.get("fitness", ""))
        if not isinstance(fit, (int, float)) or not math.isfinite(fit):
            continue
        rows.append((float(fit), int(r["eval"]), r))
    rows.sort(key=lambda t: (t[0], t[1]))
    seen, out = set(), []
    skip = set(FIXED_COLUMNS) | set(RESULT_COLUMNS) | set(names)
    for fit, _, r in rows:
        params = {n: parse_cell(r[n]) for n in names}
        key = tuple(repr(params[n]) for n in names)
        if key in seen:
            continue
        seen.add(key)
        metrics = {k: parse_cell(v) for k, v in r.items() if k not in skip and v not in ("", None)}
        found = {"stage": int(r["stage"]), "generation": int(r["generation"]), "eval": int(r["eval"])}
        out.append((params, fit, metrics, found))
        if len(out) == top_k:
            break
    return out


def select_best(cfg: RunConfig, rd: RunDir, best: Best, names: list[str],
                progress: Callable[[str], None] | None = None) -> tuple[Best, dict[str, Any]]:
    """Rescore the ``top_k`` best distinct candidates on the held-out fold; the best there is returned.

    Returns the chosen :class:`Best` (its tuning fitness, metrics and place in the history) and the
    record ``{holdout, n_holdout, top_k, candidates: [{eval, tuning_fitness, holdout_fitness, failed}],
    chosen_eval, tuning_best_eval, changed}``. A candidate that fails on the held-out fold scores inf.
    """
    from tuner.cv import plain_score
    from tuner.registry import build_objective

    sel = cfg.validation.select
    assert sel is not None
    full = build_objective(dict(cfg.objective), cfg.base_dir)
    fold, _, test = selection_split(cfg, full)
    cands = _candidates(rd, names, sel.top_k)
    table = []
    for params, fit, _, found in cands:
        score, failed, n = plain_score(test, {**best.params, **params})
        score = score if math.isfinite(score) and not failed else math.inf
        table.append({"eval": found["eval"], "tuning_fitness": fit, "holdout_fitness": score, "failed": failed})
    if not table:
        return best, {}
    i = min(range(len(table)), key=lambda j: (table[j]["holdout_fitness"], table[j]["tuning_fitness"]))
    params, fit, metrics, found = cands[i]
    chosen = Best({**best.params, **params}, fit, metrics, found["stage"], found["generation"], found["eval"],
                  best.run, dict(best.evaluation))
    record = {"holdout": str(fold), "n_holdout": n, "top_k": sel.top_k, "candidates": table,
              "chosen_eval": found["eval"], "tuning_best_eval": best.eval, "changed": found["eval"] != best.eval}
    if progress:
        progress(f"selection on held-out fold {fold}: evaluation {found['eval']} (held out "
                 f"{table[i]['holdout_fitness']:.4g}, tuning {fit:.4g}) among the {len(table)} best"
                 + ("" if record["changed"] else ": the tuning best"))
    return chosen, record


def _cv(cfg: RunConfig, rd: RunDir, params: dict[str, Any], progress: Callable[[str], None] | None,
        k: int | None = None) -> dict[str, Any]:
    """Cross-validate ``cfg`` with ``params`` as the tuning result; write the tables; return the summary."""
    from tuner.cv import cross_validate, cv_texts

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
           "per_fold": {f.name: f.cv_fitness for f in out.folds}}
    return plain(doc)


def _record(rd: RunDir, best: Best, cv: dict[str, Any] | None, selection: dict[str, Any] | None) -> Best:
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
                  cv_gap_large=cv["gap_large"])
        doc["cv"] = cv
    best = dataclasses.replace(best, evaluation=plain(ev))
    rd.write_best(best)
    if doc:
        rd.write_validation(doc)
    return best


def validate_run(cfg: RunConfig, rd: RunDir, best: Best, selection: dict[str, Any] | None,
                 progress: Callable[[str], None] | None = None) -> Best:
    """After a run (its objective's report step done): record the selection, run the CV if configured."""
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
            return _record(rd, best, None, selection)
    return _record(rd, best, cv, selection)


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
        raw = rd.config()
        source, base_dir = raw.pop("source", str(rd.file("config.yaml"))), Path(raw.pop("base_dir", rd.path))
        cfg = config_from_dict(raw, source=source, base_dir=base_dir)
        if budget_fraction is not None:
            cfg = dataclasses.replace(cfg, validation=dataclasses.replace(cfg.validation,
                                                                          budget_fraction=budget_fraction))
        best = rd.best()
        cv = _cv(cfg, rd, dict(best.params), progress, k)
        _record(rd, best, cv, None)
        write_run_report(rd.path)
    return cv
