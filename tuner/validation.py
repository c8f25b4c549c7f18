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

from tuner.config import ConfigError, RunConfig, SelectConfig, config_from_dict
from tuner.objective import as_evaluation, hook
from tuner.rundir import FIXED_COLUMNS, RESULT_COLUMNS, Best, RunDir, RunError, parse_cell, plain

__all__ = ["selection_split", "tuning_objective", "select_best", "validate_run", "cv_run_dir", "inner_split",
           "defaults_candidate", "tune_and_select", "defaults_scores", "FALLBACK_FRACTION"]

#: held-out fraction inside a CV fold whose tuning recordings lack the named ``holdout`` fold
FALLBACK_FRACTION = 0.25


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


def defaults_candidate(objective: Any, space: Any) -> tuple[dict[str, Any], list[str]] | None:
    """The objective's defaults of the searched parameters and the names whose default lies outside the
    search bounds; ``None`` without a ``default_params`` hook or when it lacks a searched name."""
    fn = hook(objective, "default_params")
    if fn is None:
        return None
    d = dict(fn())
    names = [p.name for p in space.free]
    if any(n not in d for n in names):
        return None
    params = {n: d[n] for n in names}
    return params, [n for n in names if not space[n].contains(params[n])]


def _holdout_score(test: Any, params: dict[str, Any]) -> tuple[float, str, int]:
    """Plain held-out score; a failure or a non-finite score is inf."""
    from tuner.cv import plain_score

    try:
        score, failed, n = plain_score(test, params)
    except Exception as exc:  # noqa: BLE001 - a candidate that raises on the held-out data loses
        return math.inf, f"{type(exc).__name__}: {exc}", 1
    return (score if math.isfinite(score) and not failed else math.inf), failed, n


def _defaults_entry(tune: Any, test: Any, base: dict[str, Any], dflt: tuple[dict[str, Any], list[str]]
                    ) -> tuple[dict[str, Any], dict[str, Any]]:
    """``(record entry, metrics)`` of the defaults: held-out score and tuning fitness (one call of ``tune``)."""
    params, outside = dflt
    full = {**base, **params}
    hold, failed, _ = _holdout_score(test, full)
    try:
        ev = as_evaluation(tune(full))
        fit, metrics = (float(ev.fitness), dict(ev.metrics)) if ev.status == "ok" else (math.inf, {})
    except Exception:  # noqa: BLE001 - recorded as inf, the defaults then cannot win on tuning ties
        fit, metrics = math.inf, {}
    return {"params": params, "outside_bounds": outside, "tuning_fitness": fit, "holdout_fitness": hold,
            "failed": failed}, metrics


def _pick(holdout: list[float], tuning: list[float], dflt_holdout: float | None) -> int:
    """Index of the chosen candidate (lowest held-out score, tuning fitness breaks ties); -1: the defaults,
    when their held-out score is strictly lower."""
    i = min(range(len(holdout)), key=lambda j: (holdout[j], tuning[j]))
    return -1 if dflt_holdout is not None and dflt_holdout < holdout[i] else i


def select_best(cfg: RunConfig, rd: RunDir, best: Best, names: list[str],
                progress: Callable[[str], None] | None = None) -> tuple[Best, dict[str, Any]]:
    """Rescore the ``top_k`` best distinct candidates (and the defaults) on the held-out fold; the best there wins.

    Returns the chosen :class:`Best` (its tuning fitness, metrics and place in the history; ``found``
    -1 for the defaults) and the record ``{holdout, n_holdout, top_k, candidates: [{eval, tuning_fitness,
    holdout_fitness, failed}], chosen_eval, tuning_best_eval, changed, include_defaults, defaults:
    {params, outside_bounds, tuning_fitness, holdout_fitness, failed}, defaults_chosen}``. A candidate
    that fails on the held-out fold scores inf.
    """
    from tuner.registry import build_objective

    sel = cfg.validation.select
    assert sel is not None
    full = build_objective(dict(cfg.objective), cfg.base_dir)
    fold, tune, test = selection_split(cfg, full)
    cands = _candidates(rd, names, sel.top_k)
    table = []
    n = 0
    for params, fit, _, found in cands:
        score, failed, n = _holdout_score(test, {**best.params, **params})
        table.append({"eval": found["eval"], "tuning_fitness": fit, "holdout_fitness": score, "failed": failed})
    if not table:
        return best, {}
    dflt = defaults_candidate(full, cfg.space(full)) if sel.include_defaults else None
    dentry, dmetrics = _defaults_entry(tune, test, dict(best.params), dflt) if dflt else (None, {})
    i = _pick([t["holdout_fitness"] for t in table], [t["tuning_fitness"] for t in table],
              dentry["holdout_fitness"] if dentry else None)
    record: dict[str, Any] = {"holdout": str(fold), "n_holdout": n, "top_k": sel.top_k, "candidates": table,
                              "tuning_best_eval": best.eval, "include_defaults": sel.include_defaults}
    if sel.include_defaults:
        record["defaults"] = dentry  # None: the objective has no defaults of the searched parameters
        record["defaults_chosen"] = i < 0
    if i < 0:
        assert dentry is not None
        chosen = Best({**best.params, **dentry["params"]}, dentry["tuning_fitness"], dmetrics, -1, -1, -1,
                      best.run, dict(best.evaluation))
        record.update(chosen_eval=-1, changed=True)
        held, fit, what = dentry["holdout_fitness"], dentry["tuning_fitness"], "the objective's defaults"
    else:
        params, fit, metrics, found = cands[i]
        chosen = Best({**best.params, **params}, fit, metrics, found["stage"], found["generation"], found["eval"],
                      best.run, dict(best.evaluation))
        record.update(chosen_eval=found["eval"], changed=found["eval"] != best.eval)
        held, what = table[i]["holdout_fitness"], f"evaluation {found['eval']}"
    if progress:
        progress(f"selection on held-out fold {fold}: {what} (held out {held:.4g}, tuning {fit:.4g}) among the "
                 f"{len(table)} best" + (" and the defaults" if dentry else "")
                 + ("" if record["changed"] else ": the tuning best"))
    if dentry and dentry["outside_bounds"] and progress:
        progress(f"note: the defaults of {', '.join(dentry['outside_bounds'])} lie outside the search bounds "
                 "(scored as they are)")
    return chosen, plain(record)


def inner_split(sel: SelectConfig, objective: Any, source: str = "<config>") -> tuple[str, Any, Any]:
    """``(fold name, tuning side, held-out side)`` of ``objective`` by the ``select`` rule inside a CV fold:
    the fold named ``holdout`` when the objective's own folds have it, else fold 0 of ``round(1 / f)``-fold
    with ``f = holdout`` (a number) or :data:`FALLBACK_FRACTION` (a name this part of the data lacks)."""
    key = "validation.select.holdout"
    fn = hook(objective, "cv_folds")
    if fn is None:
        raise ConfigError(source, key, f"{type(objective).__name__} has no cv_folds hook: no held-out folds")
    try:
        if isinstance(sel.holdout, str):
            match = [f for f in fn(None) if str(f[0]) == sel.holdout]
            if match:
                return str(match[0][0]), match[0][1], match[0][2]
        frac = sel.holdout if not isinstance(sel.holdout, str) else FALLBACK_FRACTION
        name, train, test = list(fn(max(2, round(1.0 / frac))))[0]
    except ValueError as exc:
        raise ConfigError(source, key, str(exc)) from None
    return str(name), train, test


def tune_and_select(cfg: RunConfig, objective: Any, tune: Callable[[Any, Callable], Any]
                    ) -> tuple[dict[str, Any], float, dict[str, Any]]:
    """The run's procedure on ``objective``: split by :func:`inner_split`, tune, choose on the held-out part.

    ``tune(objective, callback)`` runs the optimiser (``callback`` sees every :class:`tuner.loop.Generation`).
    Returns the chosen parameters, their tuning fitness and the record ``{holdout, n_holdout, candidates,
    chosen (``"tuning best"``, ``"candidate k"`` (rank k of the tuning, 1 = best) or ``"defaults"``),
    chosen_rank (0: the defaults), holdout_fitness, tuning_best_holdout, defaults_holdout, outside_bounds}``.
    """
    sel = cfg.validation.select
    assert sel is not None
    name, train, test = inner_split(sel, objective, cfg.source)
    seen: list[tuple[float, int, dict[str, Any]]] = []

    def collect(g: Any) -> None:
        for j, (p, r) in enumerate(zip(g.params, g.records)):
            ev = r.evaluation
            if ev.status == "ok" and math.isfinite(ev.fitness):
                seen.append((float(ev.fitness), g.first_eval + j, dict(p)))

    tune(train, collect)
    seen.sort(key=lambda t: (t[0], t[1]))
    cands: list[tuple[dict[str, Any], float]] = []
    keys = set()
    for fit, _, p in seen:
        key = tuple(sorted((k, repr(v)) for k, v in p.items()))
        if key not in keys:
            keys.add(key)
            cands.append((p, fit))
        if len(cands) == sel.top_k:
            break
    if not cands:
        return {}, math.inf, {"holdout": name, "chosen": "none"}
    scores = [_holdout_score(test, p) for p, _ in cands]
    hold = [s[0] for s in scores]
    dflt = defaults_candidate(objective, cfg.space(objective)) if sel.include_defaults else None
    dentry = _defaults_entry(train, test, dict(cands[0][0]), dflt)[0] if dflt else None
    i = _pick(hold, [c[1] for c in cands], dentry["holdout_fitness"] if dentry else None)
    record = {"holdout": name, "n_holdout": scores[0][2], "candidates": len(cands),
              "chosen": "defaults" if i < 0 else ("tuning best" if i == 0 else f"candidate {i + 1}"),
              "chosen_rank": i + 1, "holdout_fitness": dentry["holdout_fitness"] if i < 0 else hold[i],
              "tuning_best_holdout": hold[0],
              "defaults_holdout": dentry["holdout_fitness"] if dentry else math.nan,
              "outside_bounds": dentry["outside_bounds"] if dentry else []}
    if i < 0:
        assert dentry is not None
        return {**cands[0][0], **dentry["params"]}, dentry["tuning_fitness"], record
    return dict(cands[i][0]), cands[i][1], record


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
           "per_fold": {f.name: f.cv_fitness for f in out.folds},
           "per_fold_recordings": {f.name: list(f.recordings) for f in out.folds}}
    if out.test:  # the job's test: recordings, never in a fold, keep their own held-out score
        doc.update(test_score=out.test["tuned"], defaults_test_score=out.test["defaults"],
                   test_recordings=out.test["recordings"])
    if any(f.selection for f in out.folds):  # which candidate each fold's inner selection chose
        doc["per_fold_selection"] = {f.name: f.selection for f in out.folds}
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
                  cv_gap_large=cv["gap_large"], defaults_cv_fitness=cv["defaults_cv_score"])
        doc["cv"] = cv
    best = dataclasses.replace(best, evaluation=plain(ev))
    rd.write_best(best)
    if doc:
        rd.write_validation(doc)
    return best


def defaults_scores(cfg: RunConfig, objective: Any, space: Any = None) -> dict[str, Any]:
    """The defaults (:func:`tuner.deployment.defaults_baseline`) scored as a run's best is: ``defaults_fitness`` (the
    tuning fitness, as ``best_fitness``), ``defaults_train_fitness`` and ``defaults_test_fitness`` (the
    objective's plain ``score`` on its train and test data, as ``train_fitness``/``test_fitness``) where
    the objective has them. A defaults evaluation that fails, raises or times out scores inf."""
    from tuner.cv import scored
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
    own, and its search ``space``), the selection, the CV if configured, all recorded in ``best.yaml``."""
    if objective is not None:
        dflt = defaults_scores(cfg, objective, space)
        best = dataclasses.replace(best, evaluation=plain({**best.evaluation, **dflt}))
        if not cfg.validation.active:
            rd.write_best(best)
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
