"""Held-out selection: which fold a run holds out, the candidates of its history rescored there, and the
same procedure inside a cross-validation fold.

This is the ``validation.select`` half of :mod:`tuner.validation` (see its docstring for the YAML), kept
apart so that a run (:mod:`tuner.run`), the cross-validation (:mod:`tuner.cv`) and the validation after a
run stand on it instead of on each other. :func:`plain_score` is the one held-out score they all use: the
objective's ``score`` hook (no prior, no aggregation options), or its plain call.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

from tuner.config import ConfigError, RunConfig, SelectConfig
from tuner.objective import as_evaluation, hook
from tuner.records import Best, HistoryRow, plain
from tuner.rundir import RunDir

__all__ = ["selection_split", "tuning_objective", "select_best", "inner_split", "defaults_candidate",
           "tune_and_select", "plain_score", "scored", "FALLBACK_FRACTION"]


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
    rows = [HistoryRow.parse(r, names, rd.file("history.csv")) for r in rd.history_rows() if r.get("status") == "ok"]
    rows = sorted((r for r in rows if math.isfinite(r.fitness)), key=lambda r: (r.fitness, r.eval))
    seen, out = set(), []
    for r in rows:
        key = tuple(repr(r.params[n]) for n in names)
        if key in seen:
            continue
        seen.add(key)
        out.append((r.params, r.fitness, r.metrics, {"stage": r.stage, "generation": r.generation, "eval": r.eval}))
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
    from tuner.trust import code_outside

    sel = cfg.validation.select
    assert sel is not None
    with code_outside(cfg.origin):  # a resumed run: no code from inside its directory (tuner.trust)
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
    with ``f = holdout`` (a number) or :data:`FALLBACK_FRACTION` (a name this part of the data lacks; then
    fewer folds, down to 2, when the part has too few recordings for ``round(1 / f)``)."""
    key = "validation.select.holdout"
    fn = hook(objective, "cv_folds")
    if fn is None:
        raise ConfigError(source, key, f"{type(objective).__name__} has no cv_folds hook: no held-out folds")
    try:
        if isinstance(sel.holdout, str):
            match = [f for f in fn(None) if str(f[0]) == sel.holdout]
            if match:
                return str(match[0][0]), match[0][1], match[0][2]
        if not isinstance(sel.holdout, str):
            name, train, test = list(fn(max(2, round(1.0 / sel.holdout))))[0]
            return str(name), train, test
    except ValueError as exc:
        raise ConfigError(source, key, str(exc)) from None
    # a name this part lacks: the fallback fraction, with fewer folds when the part is small
    err = None
    for k in range(max(2, round(1.0 / FALLBACK_FRACTION)), 1, -1):
        try:
            name, train, test = list(fn(k))[0]
            return str(name), train, test
        except ValueError as exc:
            err = err or exc
    raise ConfigError(source, key, str(err))


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




def plain_score(objective: Any, params: dict[str, Any]) -> tuple[float, str, int]:
    """Plain score (fitness, failure, number of recordings) of ``params`` on ``objective``'s data."""
    fit, failed, names = scored(objective, params)
    return fit, failed, max(len(names), 1)


def scored(objective: Any, params: dict[str, Any], which: str = "train") -> tuple[float, str, tuple[str, ...]]:
    """Plain score (fitness, failure, recording names) of ``params`` on ``objective``'s ``which`` data
    (``train`` or ``test``); no names for an objective without a ``score`` hook."""
    score = hook(objective, "score")
    if score is None:
        ev = objective(params)
        return float(getattr(ev, "fitness", ev)), getattr(ev, "error", ""), ()
    s = score(params, which)
    return float(s.fitness), s.failed, tuple(str(n) for n in s.recordings)
