"""Cross-validation of tuned filter parameters: leave-one-group-out on BROAD, k-fold on other data.

A tuning score says how well parameters fit the recordings they were tuned on; users need to know
how they do on the next recording. :func:`cross_validate` answers that: for every fold it tunes the
filter on the other folds' recordings (ask/tell with any optimiser of :mod:`tuner.optimizers`, the
fitness an :func:`~objectives.attitude.aggregate.aggregate` of BROAD's per-recording total RMSE plus
an optional :func:`~objectives.attitude.aggregate.prior_penalty`), scores the held-out recordings
with the tuned parameters, and puts the result next to the filter's defaults on the same recordings.

Folds
-----
:func:`logo_folds` holds out one group at a time. For BROAD, :func:`broad_trial_groups` takes each
trial's level-2 group of category ``motion`` (undisturbed trials: rotation, translation, combined)
or ``disturbance`` (disturbed trials: tapping, vibration, stationary_magnet, attached_magnet,
office_environment, mixed) from the published ``trials.json``: the 16 shared trials fall into six
groups (rotation 5, translation 4, tapping 1, vibration 1, stationary_magnet 2, attached_magnet 3),
each trial in exactly one. :func:`kfold_folds` assigns recordings round-robin (as the objective's
``kfold`` data option does).

Scores
------
Per recording: BROAD's total RMSE (deg) over the motion samples. A filter output with non-finite
samples, or with an error growing without bound (:mod:`objectives.attitude.divergence`), is a recorded
failure scored ``failure_deg`` (default 180 deg, the largest possible error).
"""

from __future__ import annotations

import json
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from objectives.attitude.aggregate import aggregate, group_weights, prior_penalty
from tuner.space import Real, Space

__all__ = ["Fold", "TuneOptions", "FoldResult", "CVResult", "broad_trial_groups", "logo_folds", "kfold_folds",
           "search_space", "filter_class", "score_trials", "cross_validate"]


@dataclass(frozen=True)
class Fold:
    """One fold: ``name`` (the held-out group or ``fold-i``), tuning and held-out recording names."""

    index: int
    name: str
    train: tuple[str, ...]
    test: tuple[str, ...]


def broad_trial_groups(directory: str | Path, names: Sequence[str] | None = None,
                       categories: Sequence[str] = ("motion", "disturbance")) -> dict[str, str]:
    """Trial name -> its level-2 group of one of ``categories`` in ``directory/trials.json``.

    Raises
    ------
    ValueError
        ``trials.json`` missing or malformed, a requested trial not in it, or a trial with no
        group of the given categories or with more than one.
    """
    path = Path(directory) / "trials.json"
    try:
        index = json.loads(path.read_text())
        cat = {g["name"]: g["category"] for g in index["groups"] if g.get("level") == 2}
        trials = index["trials"]
    except (OSError, ValueError, KeyError, TypeError) as exc:
        raise ValueError(f"{path}: cannot read BROAD's trial index with 'groups' and 'trials' ({exc})") from None
    names = list(trials) if names is None else list(names)
    out: dict[str, str] = {}
    for n in names:
        if n not in trials:
            raise ValueError(f"{path}: trial {n!r} is not in the index")
        g = [x for x in trials[n]["groups"] if cat.get(x) in categories]
        if len(g) != 1:
            raise ValueError(f"{path}: trial {n!r} has {len(g)} level-2 groups of categories "
                             f"{list(categories)} ({g}); expected exactly one")
        out[n] = g[0]
    return out


def logo_folds(names: Sequence[str], groups: Mapping[str, str]) -> list[Fold]:
    """Leave-one-group-out folds, in order of first appearance of each group in ``names``.

    Every name is held out exactly once. Raises ``ValueError`` for a name without a group, duplicate
    names, or fewer than two groups.
    """
    names = list(names)
    if len(set(names)) != len(names):
        raise ValueError(f"logo folds: duplicate recording names in {names}")
    missing = [n for n in names if n not in groups]
    if missing:
        raise ValueError(f"logo folds: no group for recording(s) {missing}")
    order = list(dict.fromkeys(groups[n] for n in names))
    if len(order) < 2:
        raise ValueError(f"logo folds: need at least two groups, got {order}")
    return [Fold(i, g, tuple(n for n in names if groups[n] != g), tuple(n for n in names if groups[n] == g))
            for i, g in enumerate(order)]


def kfold_folds(names: Sequence[str], k: int) -> list[Fold]:
    """``k`` folds assigning recording ``i`` to fold ``i % k`` (2 <= k <= number of recordings)."""
    names = list(names)
    if not 2 <= int(k) <= len(names):
        raise ValueError(f"k-fold: need 2 <= k <= {len(names)} (number of recordings), got k={k!r}")
    return [Fold(f, f"fold-{f}", tuple(n for i, n in enumerate(names) if i % k != f),
                 tuple(n for i, n in enumerate(names) if i % k == f)) for f in range(int(k))]


def filter_class(name: str):
    """A registered filter name (``objectives.attitude.filters.FILTERS``) or ``"module:Class"``."""
    from objectives.attitude.filters import get_filter

    if ":" not in name:
        return get_filter(name)
    import importlib

    module, cls = name.split(":", 1)
    try:
        return getattr(importlib.import_module(module), cls)
    except (ImportError, AttributeError) as exc:
        raise ValueError(f"filter {name!r}: cannot import ({exc})") from None


def search_space(filter_name: str, search: Mapping[str, Any] | None = None,
                 fixed: Mapping[str, Any] | None = None) -> Space:
    """The filter's space with ``fixed`` values pinned; with ``search``, only those are searched.

    ``search`` maps parameter names to ``{low, high, scale}`` (as a config's ``parameters:``) or
    to ``None`` (keep the filter's own bounds); every other parameter is fixed at ``fixed`` or the
    filter's default.
    """
    cls = filter_class(filter_name)
    fixed = dict(fixed or {})
    unknown = sorted((set(search or {}) | set(fixed)) - set(cls.defaults))
    if unknown:
        raise ValueError(f"{filter_name}: unknown parameter(s) {unknown}; known: {sorted(cls.defaults)}")
    own = {p.name: p for p in cls.space().params}
    params = []
    for name in cls.defaults:
        if name in fixed:
            params.append(Real(name, fixed=fixed[name]))
        elif search is None:
            params.append(own.get(name, Real(name, fixed=cls.defaults[name])))
        elif name in search:
            spec = search[name]
            params.append(Real.from_dict(name, spec) if spec is not None else own[name])
        else:
            params.append(Real(name, fixed=cls.defaults[name]))
    return Space(params)


# --- scoring (runs in worker processes; recordings are loaded once per process) --------------------
_RECORDINGS: dict[str, Any] = {}


def _recording(path: str):
    if path not in _RECORDINGS:
        from objectives.attitude.data.broad import load_broad

        _RECORDINGS[path] = load_broad(path)
    return _RECORDINGS[path]


def score_trials(filter_name: str, values: Mapping[str, Any], paths: Sequence[str], init: str = "accmag",
                 failure_deg: float = 180.0) -> np.ndarray:
    """BROAD total RMSE (deg, motion samples) of the filter with ``values`` on each BROAD file.

    ``init`` is ``accmag`` (the filters' first-sample start), ``truth`` or ``broad``
    (:func:`objectives.attitude.init_broad.broad_start`). A run with non-finite output or an error
    growing without bound scores ``failure_deg``.
    """
    from objectives.attitude.divergence import unbounded_growth
    from objectives.attitude.fused_errors import error_sums
    from objectives.attitude.init_broad import broad_start

    cls = filter_class(filter_name)
    flt = cls(**{k: v for k, v in values.items() if k in cls.defaults})
    out = np.empty(len(paths))
    for i, p in enumerate(paths):
        rec = _recording(str(p))
        q0 = broad_start(rec.acc[0], rec.mag[0], cls.working_frame) if init == "broad" else init
        q = flt.run(rec, q0=q0)
        es = error_sums(q, rec.quat, rec.motion)
        out[i] = failure_deg if es.n_nonfinite or unbounded_growth(q, rec.quat, rec.motion) \
            else float(es.broad_rmse_deg[0])
    return out


# --- tuning and cross-validation ---------------------------------------------------------------------
@dataclass(frozen=True)
class TuneOptions:
    """How each fold is tuned.

    method, population, generations, seed : optimiser (any of :data:`tuner.optimizers.OPTIMIZERS`),
        its budget and the seed of its ``numpy.random.Generator`` (fold ``i`` uses ``seed + i``).
    aggregation : ``mean``, ``median``, ``worst_k`` (with ``k``) or ``cvar`` (with ``alpha``).
    group_balanced : weight recordings so every group counts equally (``mean``/``median``/``cvar``).
    prior_strength : deg added per squared RMS unit-cube distance from ``prior_center`` (the
        filter's defaults if ``None``); 0 disables the prior.
    init : start orientation, ``accmag``, ``truth`` or ``broad``.
    n_jobs : 1 evaluates serially; more uses joblib's loky processes.
    """

    method: str = "pso"
    population: int = 12
    generations: int = 8
    seed: int = 1
    aggregation: str = "mean"
    k: int | None = None
    alpha: float | None = None
    group_balanced: bool = False
    prior_strength: float = 0.0
    prior_center: Mapping[str, Any] | None = None
    init: str = "accmag"
    n_jobs: int = 1
    failure_deg: float = 180.0

    def __post_init__(self) -> None:
        from objectives.attitude.aggregate import AGGREGATIONS

        if self.aggregation not in AGGREGATIONS:
            raise ValueError(f"cv: aggregation must be one of {list(AGGREGATIONS)}, got {self.aggregation!r}")
        if self.aggregation == "worst_k" and (self.k is None or self.k < 1):
            raise ValueError(f"cv: aggregation worst_k needs k >= 1, got k={self.k!r}")
        if self.aggregation == "cvar" and (self.alpha is None or not 0 < self.alpha <= 1):
            raise ValueError(f"cv: aggregation cvar needs 0 < alpha <= 1, got alpha={self.alpha!r}")
        if self.init not in ("accmag", "truth", "broad"):
            raise ValueError(f"cv: init must be accmag, truth or broad, got {self.init!r}")
        if self.population < 1 or self.generations < 1 or self.n_jobs < 1:
            raise ValueError(f"cv: population, generations and n_jobs must be >= 1, got {self.population}, "
                             f"{self.generations}, {self.n_jobs}")
        if not (np.isfinite(self.prior_strength) and self.prior_strength >= 0):
            raise ValueError(f"cv: prior_strength must be a finite number >= 0, got {self.prior_strength!r}")

    def label(self) -> str:
        agg = self.aggregation + (f"(k={self.k})" if self.k else "") + (f"(alpha={self.alpha})" if self.alpha else "")
        parts = [f"{self.method} {self.population}x{self.generations}", agg]
        if self.group_balanced:
            parts.append("group-balanced")
        if self.prior_strength:
            parts.append(f"prior {self.prior_strength:g}")
        return ", ".join(parts)


@dataclass(frozen=True)
class FoldResult:
    """Tuning on ``fold.train`` and scores on ``fold.test``.

    params : tuned values of every parameter; fitness : best fitness (aggregate + prior);
    train_deg : per-trial RMSE of ``params`` on ``fold.train``; test_deg : same on ``fold.test``;
    n_evals, seconds : budget used.
    """

    fold: Fold
    params: dict[str, Any]
    fitness: float
    train_deg: dict[str, float]
    test_deg: dict[str, float]
    n_evals: int
    seconds: float


@dataclass
class CVResult:
    """Cross-validation of one filter and tuning setup (see :meth:`to_markdown` for the table).

    full : tuning on every recording (the tuning score users see), or ``None`` if not run;
    defaults_deg : per-trial RMSE of the filter's defaults (with ``fixed``);
    fixed : the space's fixed values that differ from the filter's defaults; free : searched names.
    """

    filter: str
    options: TuneOptions
    groups: dict[str, str]
    folds: list[FoldResult]
    defaults_deg: dict[str, float]
    full: FoldResult | None = None
    fixed: dict[str, Any] = field(default_factory=dict)
    free: tuple[str, ...] = ()

    @property
    def cv_deg(self) -> dict[str, float]:
        """Held-out RMSE of every recording (each is held out exactly once)."""
        return {n: v for f in self.folds for n, v in f.test_deg.items()}

    def summary(self) -> dict[str, float]:
        """Means (deg) over recordings, the spread (std over recordings, range of fold means), worst."""
        cv = self.cv_deg
        names = list(cv)
        c = np.array([cv[n] for n in names])
        d = np.array([self.defaults_deg[n] for n in names])
        fold_means = [np.mean(list(f.test_deg.values())) for f in self.folds]
        out = {"cv_mean": float(c.mean()), "cv_std": float(c.std()), "cv_worst": float(c.max()),
               "cv_fold_min": float(min(fold_means)), "cv_fold_max": float(max(fold_means)),
               "cv_group_mean": float(np.sum(group_weights(names, self.groups) * c)),
               "defaults_mean": float(d.mean()), "defaults_worst": float(d.max()),
               "defaults_group_mean": float(np.sum(group_weights(names, self.groups) * d))}
        if self.full is not None:
            t = np.array(list(self.full.train_deg.values()))
            out.update(train_mean=float(t.mean()), train_worst=float(t.max()), gap=float(c.mean() - t.mean()))
        return out

    def to_markdown(self) -> str:
        """Per-trial and per-group table, with the summary and the tuned parameters of each fold."""
        s = self.summary()
        cv = self.cv_deg
        fold_of = {n: f.fold.name for f in self.folds for n in f.fold.test}
        full = self.full.train_deg if self.full else {}
        lines = [f"**{self.filter}** ({self.options.label()}, init {self.options.init}"
                 + (f", fixed {self.fixed}" if self.fixed else "") + ")", "",
                 "| trial | group (held-out fold) | defaults | tuned on all (train) | LOGO-CV |",
                 "|---|---|---|---|---|"]
        for n in cv:
            tr = f"{full[n]:.2f}" if n in full else "-"
            lines.append(f"| {n} | {fold_of[n]} | {self.defaults_deg[n]:.2f} | {tr} | {cv[n]:.2f} |")
        lines += ["", "| group | n | defaults | train | LOGO-CV |", "|---|---|---|---|---|"]
        for g in dict.fromkeys(self.groups[n] for n in cv):
            ns = [n for n in cv if self.groups[n] == g]
            tr = f"{np.mean([full[n] for n in ns]):.2f}" if full else "-"
            lines.append(f"| {g} | {len(ns)} | {np.mean([self.defaults_deg[n] for n in ns]):.2f} | {tr} | "
                         f"{np.mean([cv[n] for n in ns]):.2f} |")
        tr = f"{s['train_mean']:.2f}" if "train_mean" in s else "-"
        lines += [f"| **mean** | {len(cv)} | {s['defaults_mean']:.2f} | {tr} | {s['cv_mean']:.2f} |",
                  f"| group-balanced mean | | {s['defaults_group_mean']:.2f} | | {s['cv_group_mean']:.2f} |",
                  "",
                  f"CV mean {s['cv_mean']:.3f} deg (std over trials {s['cv_std']:.2f}, fold means "
                  f"{s['cv_fold_min']:.2f}-{s['cv_fold_max']:.2f}, worst trial {s['cv_worst']:.2f}); defaults "
                  f"{s['defaults_mean']:.3f} (worst {s['defaults_worst']:.2f})"
                  + (f"; tuning score {s['train_mean']:.3f}, gap {s['gap']:+.3f}" if "train_mean" in s else "")
                  + ".", ""]
        free = list(self.free)
        if free:
            lines += ["| fold | " + " | ".join(free) + " | fitness |", "|---" * (len(free) + 2) + "|"]
            for f in ([self.full] if self.full else []) + self.folds:
                lines.append(f"| {f.fold.name} | " + " | ".join(f"{f.params[k]:.4g}" for k in free)
                             + f" | {f.fitness:.3f} |")
        return "\n".join(lines) + "\n"


def _evaluator(n_jobs: int) -> Callable[[Callable, list], list]:
    if n_jobs <= 1:
        return lambda fn, args: [fn(*a) for a in args]
    from joblib import Parallel, delayed

    pool = Parallel(n_jobs=n_jobs, backend="loky")
    return lambda fn, args: pool(delayed(fn)(*a) for a in args)


def _tune(filter_name: str, space: Space, names: Sequence[str], paths: Mapping[str, str],
          groups: Mapping[str, str], opts: TuneOptions, seed: int, run_map) -> tuple[dict, float, np.ndarray, int]:
    from tuner.optimizers import get_optimizer

    cls = filter_class(filter_name)
    center = dict(opts.prior_center) if opts.prior_center is not None else {
        **cls.defaults, **{p.name: p.fixed for p in space.params if p.is_fixed}}
    w = group_weights(names, groups) if opts.group_balanced else None
    plist = [paths[n] for n in names]
    opt = get_optimizer(opts.method)(space.dim, np.random.default_rng(seed), population=opts.population,
                                     generations=opts.generations)
    best = (None, np.inf, None)
    n = 0
    while not opt.done:
        U = opt.ask()
        cands = space.decode_batch(U)
        per = run_map(score_trials, [(filter_name, c, plist, opts.init, opts.failure_deg) for c in cands])
        F = np.empty(len(cands))
        for i, (c, s) in enumerate(zip(cands, per)):
            F[i] = aggregate(s, opts.aggregation, weights=w, k=opts.k, alpha=opts.alpha) + prior_penalty(
                c, space, center, opts.prior_strength)
            if F[i] < best[1]:
                best = (c, float(F[i]), np.asarray(s))
        n += len(cands)
        opt.tell(U, F)
    return best[0], best[1], best[2], n


def cross_validate(filter_name: str, paths: Mapping[str, str | Path], folds: Sequence[Fold], groups: Mapping[str, str],
                   space: Space | None = None, options: TuneOptions = TuneOptions(), full: bool = True,
                   progress: Callable[[str], None] | None = None) -> CVResult:
    """Tune on each fold's training recordings, score its held-out ones; see the module docstring.

    Parameters
    ----------
    filter_name : a name of :data:`objectives.attitude.filters.FILTERS`.
    paths : recording name -> BROAD ``.mat``/``.hdf5`` file.
    folds : from :func:`logo_folds` or :func:`kfold_folds`; every held-out name must be in ``paths``.
    groups : recording name -> group (group balance, per-group table).
    space : searched space (default: the filter's); fixed values of the space are passed to the filter.
    options : :class:`TuneOptions`.
    full : also tune on all recordings (the tuning score and its gap to the CV score).

    Returns
    -------
    CVResult
    """
    space = space if space is not None else search_space(filter_name)
    paths = {n: str(p) for n, p in paths.items()}
    held = [n for f in folds for n in f.test]
    if sorted(held) != sorted(set(held)) or set(held) - set(paths):
        raise ValueError(f"cross_validate: each recording must be held out once and have a path; held out {held}")
    fixed = {p.name: p.fixed for p in space.params if p.is_fixed}
    cls_defaults = filter_class(filter_name).defaults
    changed = {k: v for k, v in fixed.items() if k not in cls_defaults or v != cls_defaults[k]}
    run_map = _evaluator(options.n_jobs)
    say = progress or (lambda _m: None)
    names = list(dict.fromkeys(held))
    defaults = dict(zip(names, score_trials(filter_name, fixed, [paths[n] for n in names], options.init,
                                            options.failure_deg)))
    results = []
    todo = ([Fold(-1, "all", tuple(names), ())] if full else []) + list(folds)
    full_res = None
    for fold in todo:
        t0 = time.perf_counter()
        params, fit, train_s, n = _tune(filter_name, space, fold.train, paths, groups, options,
                                        options.seed + max(fold.index, 0), run_map)
        test_s = score_trials(filter_name, params, [paths[x] for x in fold.test], options.init,
                              options.failure_deg) if fold.test else []
        r = FoldResult(fold, dict(params), fit, dict(zip(fold.train, map(float, train_s))),
                       dict(zip(fold.test, map(float, test_s))), n, time.perf_counter() - t0)
        say(f"{filter_name} fold {fold.name}: fitness {fit:.3f}, held-out "
            f"{np.mean(test_s) if len(test_s) else float('nan'):.3f} deg ({r.seconds:.0f} s)")
        if fold.index < 0:
            full_res = r
        else:
            results.append(r)
    return CVResult(filter_name, options, dict(groups), results, defaults, full_res, changed, tuple(space.free_names))
