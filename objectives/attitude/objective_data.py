"""The filter objective's data half: the recordings it scores on (:class:`FilterData`, a base of
:class:`objectives.attitude.objective.FilterObjective`).

Each split's recordings load once per process on first use (``recordings``) and stay out of pickles; what every
evaluation reuses is computed once per split (``prepare``, :mod:`objectives.attitude.prepared`); ``preflight``
loads and checks everything before a run; ``with_data`` / ``with_recordings`` make the same objective on other
recordings, and ``cv_folds`` the folds of the tuning recordings. The data specs themselves are checked at config
load (:mod:`objectives.attitude.data_specs`).
"""

from __future__ import annotations

import copy
from collections.abc import Iterable
from pathlib import Path
from typing import Any

import numpy as np

from objectives.attitude.data.plausibility import motion_start, unit_warnings
from objectives.attitude.data.recording import Recording, RecordingError
from objectives.attitude.data_specs import check_specs as _check_specs
from objectives.attitude.data_specs import split_data as _split_data
from objectives.attitude.metrics import euler_lock_warning
from objectives.attitude.objective_options import AGG_KEYS, ungrouped_if_missing
from objectives.attitude.prepared import DataSplit, Prepared, Split, check_split, prepare

__all__ = ["FilterData"]


class FilterData:
    """The recordings of a filter objective (module docstring); the objective's fields (``train_specs``,
    ``test_specs``, ``base_dir``, ``warmup_s``, ...) and its ``_data`` / ``_prepared`` are set by
    :class:`~objectives.attitude.objective.FilterObjective`."""

    def with_data(self, data: Any) -> Any:
        """The same objective on other data (``tuner evaluate --data``): all of it is 'train'."""
        train, test = _split_data(data)
        specs = train + test
        _check_specs(specs, Path(self.base_dir), "data")
        out = type(self)(self.filter, specs, [], dict(self.fixed), self.metric, dict(self.metric_options),
                         self.q0, self.warmup_s, dict(self.report), self.base_dir, dict(self.prior))
        if self.metric_options.get("group_balanced"):  # recordings without the run's groups score ungrouped
            out.metric_options, out._notes = ungrouped_if_missing(out.metric_options, out.recordings("train"))
        return out

    def with_recordings(self, *, train: Iterable[Recording] | None = None,
                        test: Iterable[Recording] | None = None) -> Any:
        """A copy scoring the given recordings as its ``train`` / ``test`` split instead of loading them
        (a cross-validation fold, one recording of the per-trial report); a split not given is as here.

        Like loaded recordings they stay in this process: a pickled copy loads its specs again, so specs
        that name the same recordings make a worker score the same.
        """
        out = copy.copy(self)  # through __getstate__: nothing loaded or prepared is shared
        data = self._data
        for split, recs in (("train", train), ("test", test)):
            if recs is not None:
                data = data.with_split(split, recs)
        out._data = data
        return out

    def __getstate__(self) -> dict[str, Any]:
        d = dict(self.__dict__)
        d["_data"] = DataSplit()  # loaded recordings stay in the process that loaded them,
        d["_prepared"] = {}  # and so does what was computed from them
        d.pop("_cls", None)
        return d

    def __setstate__(self, d: dict[str, Any]) -> None:
        from objectives.attitude.filters import get_filter

        self.__dict__.update(d)
        self._cls = get_filter(self.filter)

    @property
    def has_test_data(self) -> bool:
        return bool(self.test_specs)

    def sample_rate(self) -> tuple[float | None, str]:
        """Rate of the training recordings (stated by synthetic specs, else read from the recordings)."""
        specs = self.train_specs or []
        if specs and all(isinstance(sp, dict) and set(sp) == {"synthetic"} and "rate_hz" in (sp["synthetic"] or {})
                         for sp in specs):  # stated in the config: no need to generate the recordings
            rates = sorted({round(float(sp["synthetic"]["rate_hz"]), 3) for sp in specs})
        else:
            try:
                rates = sorted({round(1.0 / float(r.dt), 3) for r in self.recordings("train")})
            except (RecordingError, OSError, ValueError) as exc:
                return None, f"training data not readable: {exc}"
        if not rates:
            return None, "no training recording"
        if max(rates) - min(rates) > 1e-3 * max(rates):
            return None, "training recordings differ: " + ", ".join(f"{r:g} Hz" for r in rates)
        return rates[0], "rate of the training recordings; per-sample parameters must be rescaled for another rate"

    def preflight(self) -> list[str]:
        """Load every recording once (kept for the run), check ``warmup_s`` against each, warn on units."""
        warnings: list[str] = list(self._notes)
        for split, specs in (("train", self.train_specs), ("test", self.test_specs)):
            key = "objective.data" + (f".{split}" if self.test_specs else "")
            loaded = self._data.get(split)
            recs: list[Recording] = list(loaded or [])
            for i, spec in enumerate(specs if loaded is None else []):
                where = "objective.data.all" if isinstance(spec, tuple) else f"{key}[{i}]"
                try:
                    recs += self._load([spec])
                except ValueError as exc:  # RecordingError and the loaders' own checks
                    raise ValueError(f"{where}: {exc}") from None
                except (OSError, KeyError, IndexError) as exc:  # unreadable or truncated files
                    raise ValueError(f"{where}: cannot load ({type(exc).__name__}: {exc})") from None
            if split == "train" and not recs:  # an empty list, or a selection that keeps no recording
                raise ValueError(f"{key}: no recordings to score; give at least one data spec")
            for rec in recs:
                if self.warmup_s >= rec.duration_s:
                    raise ValueError(f"objective.warmup_s: {self.warmup_s:g} s is not shorter than recording "
                                     f"{rec.name!r} ({rec.duration_s:.4g} s, {rec.source or 'no source'})")
                if rec.quat is not None and not np.isfinite(rec.quat[self._mask(rec)]).all(axis=1).any():
                    raise ValueError(
                        f"{key}: recording {rec.name!r} ({rec.source or 'no source'}) has no sample to score: none "
                        f"with a finite truth quaternion inside its motion mask after warmup_s = {self.warmup_s:g} "
                        f"s ({int(rec.motion.sum())} of {rec.motion.size} samples in motion); give truth for the "
                        "motion, a shorter warm-up, or leave the recording out")
                warnings += unit_warnings(rec) + list(rec.meta.get("warnings", []))  # units, what reading found
                warnings += self._start_warning(rec) + euler_lock_warning(rec.name, self.metric, rec.quat,
                                                                          self._mask(rec))
            if loaded is None:
                self._data = self._data.with_split(split, recs)
        return list(dict.fromkeys(warnings))  # windows of one file read it once each: one line per finding

    def start_init(self) -> Any:
        """The start the filter uses: its fixed ``init`` option unless ``auto``, else ``q0``."""
        init = self.fixed.get("init", self._cls.defaults.get("init", "auto"))
        return self.q0 if init == "auto" else init

    def _start_warning(self, rec: Recording) -> list[str]:
        """A warning when ``rec`` starts in motion under an ``accmag``/``broad`` start without a warm-up
        (:func:`objectives.attitude.data.plausibility.motion_start`)."""
        init = self.start_init()
        if self.warmup_s > 0 or not (init is None or (isinstance(init, str) and init in ("accmag", "broad"))):
            return []
        why = motion_start(rec)
        if not why:
            return []
        return [f"{rec.name}: starts in motion ({why}), so the {init or 'accmag'} start orientation is wrong; "
                "for scoring set `init: truth` (objective.fixed) or skip the start with `objective.warmup_s` "
                "(e.g. 2.0)"]

    # --- data ---------------------------------------------------------------------------------
    def _load(self, specs: list) -> list[Recording]:
        from objectives.attitude.data.loaders import load_recordings

        base = Path(self.base_dir)
        out: list[Recording] = []
        for spec in specs:
            if isinstance(spec, tuple) and spec[0] == "subset":  # a cross-validation fold: these recordings
                _, items, names = spec
                out += [r for r in self._load(list(items)) if r.name in names]
            elif isinstance(spec, tuple):  # k-fold: round-robin assignment of the listed recordings
                which, items, k, fold = spec
                recs = [r for s in items for r in load_recordings(s, base)]
                out += [r for i, r in enumerate(recs) if (i % k == fold) == (which == "kfold-test")]
            else:
                out += load_recordings(spec, base)
        return out

    def recordings(self, split: Split = "train") -> tuple[Recording, ...]:
        """The recordings of ``split``, loaded on first use (see :class:`~objectives.attitude.prepared.DataSplit`)."""
        recs = self._data.get(check_split(split))
        if recs is None:
            recs = tuple(self._load(self.train_specs if split == "train" else self.test_specs))
            self._data = self._data.with_split(split, recs)
        return recs

    def prepare(self, split: Split = "train") -> Prepared:
        """What every evaluation on ``split`` reuses, computed on the split's first evaluation and kept
        (:func:`objectives.attitude.prepared.prepare`: recordings, groups, disturbance inputs). One split at a
        time, not both at once: a worker that tunes never scores the held-out split, so never loads it."""
        split = check_split(split)
        if split not in self._prepared:
            self._prepared[split] = prepare(self, split)
        return self._prepared[split]

    def _mask(self, rec: Recording) -> np.ndarray:
        mask = rec.motion.copy()
        if self.warmup_s > 0:
            mask[: int(round(self.warmup_s / rec.dt))] = False
        return mask

    # --- cross-validation (tuner cv) -----------------------------------------------------------------
    def cv_folds(self, k: int | None = None, by: str | None = None) -> list[tuple[str, Any, Any]]:
        """Folds over the objective's tuning recordings: ``(name, tune on, held out)``.

        ``test:`` recordings are never pooled into the folds: they keep their own held-out score, which
        the engine reports next to the CV score (:func:`tuner.cv.cross_validate`).

        Without ``k``, recordings that are all BROAD trials (a ``trials.json`` beside them) are grouped by
        BROAD's level-2 motion/disturbance group and each group is held out once (leave-one-group-out);
        otherwise, or with ``k``, recordings are assigned round-robin to ``k`` folds (default ``min(5, n)``).
        The tuning side keeps the objective's metric, options and prior; the held-out side keeps the metric
        without the aggregation options (each held-out recording counts once, as in the plain metric), and
        the engine scores it with ``score`` (no prior). With ``by="dataset"`` each dataset (the data
        sources' ``dataset:`` labels, :func:`objectives.attitude.data.loaders.dataset_label`) is held out once.
        """
        from objectives.attitude.objective_options import recording_groups
        from objectives.attitude.trials import check_unique_names, kfold_folds, logo_folds

        recs = list(self.recordings("train"))
        names = [r.name for r in recs]
        check_unique_names(recs, "objective.data")
        if len(recs) < 2:
            raise ValueError(f"objective.data{'.train' if self.test_specs else ''}: cross-validation needs >= 2 "
                             f"tuning recordings, got {len(recs)} (test recordings are never pooled into folds)")
        groups: dict[str, str] | None = None
        if by is not None:
            if by != "dataset":
                raise ValueError(f"unknown grouping {by!r}; allowed: dataset")
            groups = {r.name: str(r.meta.get("dataset", "default")) for r in recs}
            if len(set(groups.values())) < 2:
                raise ValueError(f"leaving one dataset out needs >= 2 datasets; every tuning recording is in "
                                 f"dataset {next(iter(groups.values()))!r} (label the data sources with "
                                 "`dataset: NAME`)")
        elif k is None:
            try:
                groups = recording_groups(recs, "broad")
            except ValueError:
                groups = None
        if groups is not None and len(set(groups.values())) >= 2:
            folds = logo_folds(names, groups)
        else:
            folds = kfold_folds(names, min(5, len(recs)) if k is None else int(k))
        parts = [(f.name, list(f.test)) for f in folds]
        specs = list(self.train_specs)
        plain = {k: v for k, v in self.metric_options.items() if k not in AGG_KEYS}
        by_name = dict(zip(names, recs))
        out = []
        for fname, held in parts:
            rest = [n for n in names if n not in held]
            sides = []
            for keep, opts in ((rest, dict(self.metric_options)), (held, plain)):
                obj = type(self)(self.filter, [("subset", specs, tuple(keep))], [], dict(self.fixed),
                                 self.metric, opts, self.q0, self.warmup_s,
                                 dict(self.report), self.base_dir, dict(self.prior))
                sides.append(obj.with_recordings(train=[by_name[n] for n in keep]))
            out.append((fname, sides[0], sides[1]))
        return out
