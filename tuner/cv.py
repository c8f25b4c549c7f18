"""Cross-validation of a tuning job: tune on the other folds, score the held-out fold.

``tuner cv CONFIG`` asks the objective for its folds through the ``cv_folds`` hook
(:class:`tuner.objective.TunableObjective`): ``cv_folds(k) -> [(name, train_objective, test_objective)]``,
e.g. leave-one-group-out over a dataset's recording groups, or ``k``-fold. For every fold the config's
optimiser tunes ``train_objective`` on the config's search space and parallel backend
(:func:`tuner.loop.minimize`), and ``test_objective``'s plain score (its ``score`` hook, no prior) is
taken for the tuned parameters and for the objective's defaults. The job is also tuned once on all of
its data: its tuning score against the CV score is the generalisation gap.

Output directory ``<output>/cv/<name>-<UTC stamp>/``: ``cv.md`` (per-fold table with the tuned
parameters, summary with mean and spread over folds and over held-out recordings) and ``cv.csv``
(one row per fold). The engine knows nothing of the domain: what a fold is belongs to the objective.

The same cross-validation runs after ``tuner run`` when the config has ``validation: {cv: ...}``, and
``tuner cv RUN_DIR`` runs it for a finished run (:mod:`tuner.validation`); then the run's own best
parameters give the tuning score (``full_params``: no second tuning on all data) and the tables go
into the run directory. The gap is *large* by :meth:`tuner.config.ValidationConfig.gap_is_large`
(default: more than 25 % of the tuning score).

With ``validation.select`` the CV measures the whole procedure a run uses (:func:`tuner.validation.tune_and_select`):
each fold's tuning recordings are split again into tune / held-out parts by the ``select`` rule, and the
fold's parameters are the candidate (or the defaults, ``include_defaults``) that does best on that inner
held-out part; ``FoldOutcome.selection`` says which won, the ``chosen`` column of the tables shows it.
The tuning on all data (``full``) follows the same procedure.
"""

from __future__ import annotations

import csv
import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from tuner.config import ConfigError, RunConfig, ValidationConfig
from tuner.deployment import DEFAULTS_MEANING, defaults_baseline
from tuner.loop import minimize
from tuner.objective import hook
from tuner.selection import plain_score, scored, tune_and_select
from tuner.setup import LiveMap, build_objective, new_optimizer, worker_count

__all__ = ["cv_by", "transfer_rows", "transfer_table", "FoldOutcome", "CVOutcome", "cross_validate", "write_cv",
           "cv_texts", "scaled_budget", "plain_score",
           "scored", "scores_on_test_data"]


@dataclass
class FoldOutcome:
    """One fold: held-out recordings, tuned parameters and the scores (lower is better)."""

    name: str
    n_test: int
    params: dict[str, Any]
    train_fitness: float
    cv_fitness: float
    default_fitness: float
    failed: str = ""
    selection: dict[str, Any] = field(default_factory=dict)
    recordings: tuple[str, ...] = ()  # the held-out recordings (as the objective names them)


@dataclass
class CVOutcome:
    """All folds plus the tuning on all data (``full``) and, where the job has ``test:`` data (never in the
    folds), ``test``: ``{n, recordings, tuned, defaults, failed}``, its own held-out score of the tuning on
    all data (``full``) and of the defaults."""

    name: str
    folds: list[FoldOutcome]
    full: FoldOutcome | None
    seconds: float = 0.0
    searched: list[str] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    test: dict[str, Any] = field(default_factory=dict)
    by: str | None = None  # "dataset": each fold holds out one dataset (the transfer table)

    def _col(self, key: str) -> np.ndarray:
        return np.array([getattr(f, key) for f in self.folds], float)

    def summary(self) -> dict[str, float]:
        """Mean and spread over folds; means weighted by held-out recordings; the gap to the tuning score."""
        cv, de, n = self._col("cv_fitness"), self._col("default_fitness"), self._col("n_test")
        out = {"cv_fold_mean": float(np.mean(cv)), "cv_fold_std": float(np.std(cv)),
               "cv_fold_worst": float(np.max(cv)), "defaults_fold_mean": float(np.mean(de)),
               "defaults_fold_std": float(np.std(de)), "defaults_fold_worst": float(np.max(de)),
               "cv_mean": float(np.sum(cv * n) / np.sum(n)), "defaults_mean": float(np.sum(de * n) / np.sum(n))}
        if self.full is not None:
            out["tuning_score"] = self.full.cv_fitness  # tuned on all, scored like the held-out folds
            out["gap"] = out["cv_mean"] - self.full.cv_fitness
        return out


def scores_on_test_data(objective: Any, params: dict[str, Any] | None,
                        defaults: dict[str, Any] | None) -> dict[str, Any]:
    """``{n, recordings, tuned, defaults, failed}`` on the objective's ``test:`` data; empty without any."""
    has = hook(objective, "has_test_data")
    if has is None or not has() or hook(objective, "score") is None:
        return {}
    tuned, failed, names = scored(objective, params, "test") if params else (math.nan, "no parameters", ())
    dflt = scored(objective, defaults, "test")[0] if defaults is not None else math.nan
    if not names and defaults is not None:
        names = scored(objective, defaults, "test")[2]
    return {"n": len(names), "recordings": list(names), "tuned": tuned, "defaults": dflt, "failed": failed}


def scaled_budget(cfg: RunConfig, fraction: float) -> RunConfig:
    """``cfg`` with its generations (and ``max_evals``) times ``fraction`` (at least 1; 1.0: unchanged)."""
    import dataclasses

    if fraction >= 1.0:
        return cfg
    opt = cfg.optimizer
    gens = None if opt.generations is None else max(1, round(opt.generations * fraction))
    options = dict(opt.options)
    if isinstance(options.get("max_evals"), int):
        options["max_evals"] = max(1, round(options["max_evals"] * fraction))
    return dataclasses.replace(cfg, optimizer=dataclasses.replace(opt, generations=gens, options=options))


def _tune(cfg: RunConfig, objective: Any, evaluate: Callable, stage: int,
          callback: Callable | None = None) -> tuple[dict[str, Any], float]:
    space = cfg.space(objective)
    if space.dim == 0:
        raise ConfigError(cfg.source, "parameters", "every parameter is fixed: nothing to tune")
    res = minimize(objective, space, new_optimizer(cfg, stage, space, None, objective), evaluate=evaluate,
                   callback=callback)
    if res.best is None:
        return {}, math.inf
    return dict(res.best.params), float(res.best.fitness)


def _procedure(cfg: RunConfig, objective: Any, evaluate: Callable) -> tuple[dict[str, Any], float, dict[str, Any]]:
    """Tune ``objective`` as a run would: plainly, or with the final selection of ``validation.select``."""
    if cfg.validation.select is None:
        return (*_tune(cfg, objective, evaluate, stage=0), {})
    return tune_and_select(cfg, objective, lambda obj, cb: _tune(cfg, obj, evaluate, 0, cb))


def cv_by(cfg: RunConfig, k: int | None) -> str | None:
    """The grouping the objective's ``cv_folds`` is asked for besides ``k``: ``"dataset"`` with
    ``validation: {cv: {by: dataset}}`` (leave one dataset out) unless an explicit ``k`` overrides it, else None."""
    return "dataset" if k is None and cfg.validation.cv == "dataset" else None


def cross_validate(cfg: RunConfig, k: int | None = None, full: bool = True,
                   progress: Callable[[str], None] | None = None, budget_fraction: float = 1.0,
                   full_params: dict[str, Any] | None = None) -> CVOutcome:
    """Cross-validate ``cfg``: tune per fold with its optimiser and backend, score the held-out fold.

    Parameters
    ----------
    cfg : RunConfig
        The job (objective, search space, optimiser, parallel backend, seed).
    k : int, optional
        Number of folds where the objective uses k-fold (``None``: the objective's choice, e.g. its groups).
    full : bool
        Also tune on all the data, for the tuning score and the gap.
    budget_fraction : float
        Each fold (and the tuning on all data) runs this fraction of the config's generations, in (0, 1].
    full_params : dict, optional
        Parameters already tuned on all the data (a run's best): they give the tuning score and the gap
        instead of a new tuning on all data (``full`` is then ignored).

    Raises
    ------
    ConfigError
        The objective has no ``cv_folds`` hook, or gives fewer than two folds.
    """
    from tuner.registry import say_imports

    t0 = time.time()
    say = progress or (lambda msg: None)
    if not 0 < budget_fraction <= 1:
        raise ConfigError(cfg.source, "validation.budget_fraction", f"expected a number in (0, 1], got "
                          f"{budget_fraction!r}")
    cfg = scaled_budget(cfg, budget_fraction)
    if full_params is None:  # `tuner cv CONFIG` (a run's CV follows its run, which said it already)
        say_imports(cfg.objective, cfg.source)
    objective = build_objective(cfg)
    folds_fn = hook(objective, "cv_folds")
    if folds_fn is None:
        raise ConfigError(cfg.source, "objective", f"{type(objective).__name__} has no cv_folds hook: "
                          "it cannot be cross-validated")
    by = cv_by(cfg, k)
    try:
        folds = list(folds_fn(k, by=by) if by else folds_fn(k))
    except ValueError as exc:
        raise ConfigError(cfg.source, "validation.cv.by" if by else "objective", str(exc)) from None
    if len(folds) < 2:
        raise ConfigError(cfg.source, "objective", f"cross-validation needs >= 2 folds, got {len(folds)}")
    n_jobs, notes = worker_count(cfg, cfg.space(objective))
    out = CVOutcome(cfg.name, [], None, notes=notes, searched=[p.name for p in cfg.space(objective).free], by=by)
    defaults = defaults_baseline(objective, cfg.space(objective))  # fixed values wherever written
    nested = cfg.validation.nested
    if nested:
        declared = hook(objective, "default_space")
        known = {p.name for p in cfg.space(objective).params} | (
            {p.name for p in declared().params} if declared is not None else set())
        unknown = [n for n in nested if n not in known]
        if unknown:
            raise ConfigError(cfg.source, f"validation.cv.nested.choose.{unknown[0]}",
                              f"not a parameter of this job; allowed: {', '.join(sorted(known))}")

    def procedure(c: RunConfig, obj: Any) -> tuple[dict[str, Any], float, dict[str, Any]]:
        evaluate = LiveMap(c, n_jobs)
        try:
            return _procedure(c, obj, evaluate)
        finally:
            evaluate.close()

    def nested_procedure(obj: Any) -> tuple[dict[str, Any], float, dict[str, Any]]:
        """The config's procedure, after the inner loop's choice of the nested options (if any)."""
        if not nested:
            return procedure(cfg, obj)
        from tuner.nested import choose

        choice, ccfg, record = choose(cfg, obj, procedure, say)
        params, fit, sel = procedure(ccfg, obj)
        return params, fit, {**sel, "nested": record}

    for i, (name, train, test) in enumerate(folds):
        params, train_fit, sel = nested_procedure(train)
        cv_fit, failed, held = scored(test, params) if params else (math.inf, "no successful evaluation", ())
        de_fit, _, held_d = scored(test, defaults) if defaults is not None else (math.nan, "", ())
        held = held or held_d
        out.folds.append(FoldOutcome(str(name), max(len(held), 1), params, train_fit, cv_fit, de_fit, failed, sel,
                                     held))
        say(f"fold {i + 1}/{len(folds)} {name}: tuned {train_fit:.4g}, held out {cv_fit:.4g}, defaults {de_fit:.4g}"
            + (f"; chosen on inner fold {sel['holdout']}: {sel['chosen']}" if sel.get("holdout") else "")
            + (f"; nested choice {sel['nested']['chosen']}" if sel.get("nested") else ""))
    if full or full_params is not None:
        sel = {}
        if full_params is not None:
            params, train_fit = dict(full_params), math.nan
        else:
            params, train_fit, sel = nested_procedure(objective)
        # its score on all data as the folds count it (held-out scores weighted by recordings), so the
        # gap compares like with like whatever aggregation or prior the tuning used
        sc = [(plain_score(test, params), n) for (_, _, test), n in zip(folds, [f.n_test for f in out.folds])] \
            if params else []
        plain = sum(s[0] * n for s, n in sc) / sum(n for _, n in sc) if sc else math.nan
        out.full = FoldOutcome("all", sum(f.n_test for f in out.folds), params, train_fit, plain, math.nan,
                               selection=sel, recordings=tuple(r for f in out.folds for r in f.recordings))
        say(("all data: the run's best" if full_params is not None else f"all data: tuned {train_fit:.4g}")
            + f", scored as the folds {plain:.4g}" + (f"; chosen on fold {sel['holdout']}: {sel['chosen']}"
                                                      if sel.get("holdout") else "")
            + (f"; nested choice {sel['nested']['chosen']}" if sel.get("nested") else ""))
        out.test = scores_on_test_data(objective, params, defaults)
        if out.test:
            say(f"test recordings (never in the folds): tuned {out.test['tuned']:.4g}, defaults "
                f"{out.test['defaults']:.4g}")
    out.seconds = time.time() - t0
    return out


def transfer_rows(out: CVOutcome) -> list[dict[str, Any]]:
    """The transfer table of a leave-one-dataset-out CV (``out.by == "dataset"``; else ``[]``): one row per
    dataset, ``{dataset, n, defaults, tuned, difference}``: the defaults and the parameters tuned on the other
    datasets, both scored on this dataset's recordings, and tuned - defaults (negative: tuning carries over)."""
    if out.by != "dataset":
        return []
    return [{"dataset": f.name, "n": f.n_test, "defaults": f.default_fitness, "tuned": f.cv_fitness,
             "difference": f.cv_fitness - f.default_fitness} for f in out.folds]


def transfer_table(rows: list[dict[str, Any]]) -> list[str]:
    """Markdown lines of :func:`transfer_rows` (``[]`` without rows)."""
    if not rows:
        return []
    worse = [r["dataset"] for r in rows if r["difference"] > 0]
    return ["## Transfer between datasets", "",
            "Each dataset held out once: tuned on the other datasets, scored on this one, beside the defaults "
            "scored on the same recordings (difference = tuned - defaults; negative: the tuning carries over).", "",
            "| dataset (held out) | n | defaults | tuned on the others | difference |", "|---|---|---|---|---|",
            *(f"| {r['dataset']} | {r['n']} | {_fmt(r['defaults'])} | {_fmt(r['tuned'])} | "
              f"{_fmt_signed(r['difference'])} |" for r in rows), "",
            (f"Tuning on the other datasets is worse than the defaults on: {', '.join(worse)}." if worse
             else "Tuning on the other datasets beats the defaults on every dataset."), ""]


def _fmt_signed(v: float) -> str:
    return "-" if math.isnan(v) else f"{v:+.4g}"


def _choice(choice: dict[str, Any]) -> str:
    """``a=1, b=x`` of a nested choice (``""`` without one)."""
    return ", ".join(f"{k}={v}" for k, v in choice.items())


def _fmt(v: Any) -> str:
    if isinstance(v, float):
        return "-" if math.isnan(v) else f"{v:.4g}"
    return str(v)


def write_cv(out: CVOutcome, directory: str | Path, validation: ValidationConfig | None = None) -> Path:
    """Write ``cv.md`` and ``cv.csv`` into ``directory`` (created); returns the directory."""
    d = Path(directory)
    d.mkdir(parents=True, exist_ok=True)
    md, table = cv_texts(out, validation)
    from tuner.safe_io import write_atomic

    write_atomic(d / "cv.csv", table, fsync=False)  # never through a link of either kind (tuner.safe_io)
    write_atomic(d / "cv.md", md, fsync=False)
    return d


def cv_texts(out: CVOutcome, validation: ValidationConfig | None = None) -> tuple[str, str]:
    """``(cv.md, cv.csv)`` of ``out``; ``validation`` says when the gap is large (default thresholds)."""
    import io

    validation = validation or ValidationConfig()
    rows = out.folds + ([out.full] if out.full else [])
    names = list(out.searched)
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(["fold", "n_test", "train_fitness", "cv_fitness", "defaults_fitness", "failed", "chosen",
                "inner_holdout", "nested_choice", "recordings", *names])
    for f in rows:
        w.writerow([f.name, f.n_test, f.train_fitness, f.cv_fitness, f.default_fitness, f.failed,
                    f.selection.get("chosen", ""), f.selection.get("holdout", ""),
                    _choice((f.selection.get("nested") or {}).get("chosen") or {}), ";".join(f.recordings),
                    *[f.params.get(n, "") for n in names]])
    t = out.test
    if t:  # the job's test: recordings, never in a fold: the tuning on all data and the defaults scored on them
        w.writerow(["test", t["n"], "", t["tuned"], t["defaults"], t["failed"], "", "", "", ";".join(t["recordings"]),
                    *[out.full.params.get(n, "") if out.full else "" for n in names]])
    s = out.summary()
    with_sel = any(f.selection for f in rows)
    sel_head, sel_cols = ("chosen (inner held-out fold) | ", 1) if with_sel else ("", 0)

    def chosen(f: FoldOutcome) -> str:
        if not with_sel:
            return ""
        s = f.selection
        text = (f"{s.get('chosen', '')} ({s.get('holdout', '')}: {_fmt(s.get('holdout_fitness', math.nan))})"
                if s.get("holdout") else "")
        if s.get("nested"):  # tuner.nested: the options the inner loop chose for this fold
            n = s["nested"]
            text += ("; " if text else "") + f"options {_choice(n['chosen'])} ({n['holdout']})"
        return text + " | "

    lines = [f"# Cross-validation of {out.name}", "",
             f"{len(out.folds)} folds, {out.seconds:.0f} s. Each fold: tuned on the other folds, scored on the "
             f"held-out recordings (plain metric, no prior); {DEFAULTS_MEANING}, scored on the same recordings."
             + (" Each fold's final choice: the best of the tuning's top candidates"
                " (and the defaults, where included) on an inner held-out part of the fold's tuning recordings,"
                " as `validation.select` does in a run." if with_sel else ""), "",
             "| fold (held out) | n | tuned: train | tuned: held out (CV) | defaults: held out | " + sel_head
             + " | ".join(names) + " |", "|" + "---|" * (5 + sel_cols + len(names))]
    for f in out.folds:
        lines.append(f"| {f.name} | {f.n_test} | {_fmt(f.train_fitness)} | {_fmt(f.cv_fitness)}"
                     f"{' (failed)' if f.failed else ''} | {_fmt(f.default_fitness)} | {chosen(f)}"
                     + " | ".join(_fmt(f.params.get(n, "")) for n in names) + " |")
    if out.full:
        lines.append(f"| *all (tuning)* | {out.full.n_test} | {_fmt(out.full.train_fitness)} | "
                     f"{_fmt(out.full.cv_fitness)} (on all, not held out) | | {chosen(out.full)}"
                     + " | ".join(_fmt(out.full.params.get(n, "")) for n in names) + " |")
    if out.test:
        t = out.test
        lines.append(f"| *test (never in a fold)* | {t['n']} | | {_fmt(t['tuned'])} (tuned on all)"
                     f"{' (failed)' if t['failed'] else ''} | {_fmt(t['defaults'])} | {'| ' if with_sel else ''}"
                     + " | ".join("" for _ in names) + " |")
    lines += ["", "Recordings held out by each fold (the job's tuning recordings only; `test:` recordings are "
                  "never pooled into the folds):", ""]
    lines += [f"- {f.name}: {', '.join(f.recordings) or '-'}" for f in out.folds]
    if out.test:
        lines.append(f"- test: {', '.join(out.test['recordings']) or '-'}")
    lines += ["", "| | tuned (CV) | defaults |", "|---|---|---|",
              f"| mean over held-out recordings | {s['cv_mean']:.4g} | {s['defaults_mean']:.4g} |",
              f"| mean over folds (std) | {s['cv_fold_mean']:.4g} ({s['cv_fold_std']:.3g}) | "
              f"{s['defaults_fold_mean']:.4g} ({s['defaults_fold_std']:.3g}) |",
              f"| worst fold | {s['cv_fold_worst']:.4g} | {s['defaults_fold_worst']:.4g} |"]
    if "gap" in s:
        lines += ["", f"Tuning score on all data {s['tuning_score']:.4g}; CV {s['cv_mean']:.4g}; "
                      f"gap {s['gap']:+.3g}" + (f" (large, {validation.gap_rule()}: the tuned parameters do not "
                                                "carry over)" if validation.gap_is_large(s["gap"], s["tuning_score"])
                                                else "") + "."]
    if s["cv_mean"] > s["defaults_mean"]:
        lines += ["", "CV score worse than the defaults': tuning does not help on unseen recordings."]
    lines += [*(f"- {n}" for n in out.notes), ""]
    lines += transfer_table(transfer_rows(out))
    return "\n".join(lines), buf.getvalue()
