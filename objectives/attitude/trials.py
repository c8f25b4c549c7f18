"""BROAD's trial groups, folds over recording names, and a filter scored on trial files.

This is the domain's part of cross-validation; the cross-validation itself (tune on the other folds,
score the held-out one, the tables) is the engine's (:mod:`tuner.cv`, ``tuner cv CONFIG``), which gets
its folds from the filter objective's ``cv_folds`` hook
(:meth:`objectives.attitude.objective.FilterObjective.cv_folds`, built on :func:`logo_folds` and
:func:`kfold_folds` below).

Folds
-----
:func:`logo_folds` holds out one group at a time. For BROAD, :func:`broad_trial_groups` takes each
trial's level-2 group of category ``motion`` (undisturbed trials: rotation, translation, combined)
or ``disturbance`` (disturbed trials: tapping, vibration, stationary_magnet, attached_magnet,
office_environment, mixed) from the published ``trials.json``: the 16 shared trials fall into six
groups (rotation 5, translation 4, tapping 1, vibration 1, stationary_magnet 2, attached_magnet 3),
each trial in exactly one. :func:`kfold_folds` assigns recordings round-robin (as the objective's
``cv_folds(k)`` does).

Scores
------
:func:`score_trials`: per recording, BROAD's total RMSE (deg) over the motion samples. A filter output
with non-finite samples, or with an error growing without bound (:mod:`objectives.attitude.divergence`),
is a recorded failure scored ``failure_deg`` (default 180 deg, the largest possible error). Benchmarks
that score many parameter sets on the same trials (a grid, several sampling rates) use it directly.
"""

from __future__ import annotations

import json
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from tuner.space import Real, Space

__all__ = ["Fold", "broad_trial_groups", "logo_folds", "kfold_folds", "check_unique_names", "search_space",
           "filter_class", "load_trial", "score_trials"]


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
        raise ValueError(f"cv: need 2 <= k <= {len(names)} (recordings), got k={k!r}")
    return [Fold(f, f"fold-{f}", tuple(n for i, n in enumerate(names) if i % k != f),
                 tuple(n for i, n in enumerate(names) if i % k == f)) for f in range(int(k))]


def check_unique_names(recordings: Sequence[Any], where: str) -> None:
    """ValueError naming every repeated recording name, where each comes from, and the fix (``name:``): folds,
    groups and per-recording scores are keyed by name."""
    by_name: dict[str, list[str]] = {}
    for r in recordings:
        by_name.setdefault(r.name, []).append(r.source or "no source")
    rep = {n: s for n, s in by_name.items() if len(s) > 1}
    if rep:
        listed = "; ".join(f"{n!r} {len(s)} times ({', '.join(sorted(set(s)))})" for n, s in rep.items())
        raise ValueError(f"{where}: recording names repeat: {listed}; cross-validation and per-recording scores "
                         "need unique names: give each data spec its own `name:` (csv), or cut windows with "
                         "start_s/stop_s, which are named file@start-stop")


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


def load_trial(path: str | Path):
    """The BROAD recording of ``path`` (``.mat``/``.hdf5``), loaded once per process."""
    path = str(path)
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
        rec = load_trial(p)
        q0 = broad_start(rec.acc[0], rec.mag[0], cls.working_frame) if init == "broad" else init
        q = flt.run(rec, q0=q0)
        es = error_sums(q, rec.quat, rec.motion)
        out[i] = failure_deg if es.n_nonfinite or unbounded_growth(q, rec.quat, rec.motion) \
            else float(es.broad_rmse_deg[0])
    return out
