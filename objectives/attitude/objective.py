"""The filter objective: run a filter on recordings against ground truth and score it.

YAML section (``objective:``)::

    kind: filter
    filter: faekf                       # any name of objectives.attitude.filters.FILTERS
    fixed: {window: 400}                # filter values that are not searched (override defaults)
    data:                               # a list of data specs (tune and report on all of them) ...
      - synthetic: {generator: bench6dof, duration_s: 60, seed: 1}
    # ... or a split into tuning and held-out recordings
    data:
      train: [{broad: {dir: ../shared/data/broad, trials: [01_undisturbed_slow_rotation_A]}}]
      test:  [{broad: {dir: ../shared/data/broad, trials: [03_undisturbed_slow_rotation_C]}}]
    # ... or k-fold over one list: fold `fold` of `k` is held out (recordings assigned round-robin)
    data: {all: [...], kfold: {k: 4, fold: 0}}
    metric: euler_mse_geomean           # see METRICS
    metric_options: {weights: [1, 1, 1], normalize: false}
    # aggregation over recordings and a prior toward the defaults (objectives.attitude.objective_options):
    # metric_options: {aggregate: mean|median|worst_k|cvar, k: 3, alpha: 0.5, group_balanced: true, groups: broad}
    # prior: {strength: 3.0, center: defaults}
    q0: accmag                          # start: accmag (first sample), truth or broad; a filter's own
                                        # `init` (fixed: {init: broad}, or a --params file) wins
    warmup_s: 0.0                       # seconds at the start of each recording left out of metrics
    report: {traces: true, per_trial_optimum: false, per_trial_budget: 120}

Metrics (lower is better):

``euler_mse_geomean``  FAEKF paper eq. 35 over the recordings (rad^2); ``metric_options.weights``
                       are per-axis exponents, ``normalize: true`` takes the geometric mean of all
                       MSEs instead of the paper's cube root of the product.
``euler_rmse_mean``    mean over recordings of the mean per-axis Euler RMSE (deg).
``mse_1d``             thesis eq. 3.18 on the tilt angle (rad^2), mean over recordings.
``broad_mean_rmse``    mean over recordings of BROAD's total RMSE (deg) on motion samples: the
                       criterion of BROAD's trial-agnostic good parameters (TAGP).
``broad_total_rmse``   BROAD's total RMSE (deg) pooled over the motion samples of all recordings.
``heading_rmse_mean``, ``inclination_rmse_mean``
                       mean over recordings of BROAD's heading / inclination RMSE (deg): from the error
                       quaternion, the same at any mounting (the Euler metrics warn near pitch +-90 deg).

``metric_options.heading_offset: remove`` compares each recording with its truth turned by the constant heading
offset that fits the estimate best (:func:`objectives.attitude.metrics.heading_offset`).

A filter whose output is not finite, or whose error grows without bound (:mod:`objectives.attitude.divergence`)
is a failed evaluation naming the recording. Each split's recordings load once per worker, on first use,
and :meth:`FilterObjective.prepare` computes what its evaluations reuse (:mod:`objectives.attitude.prepared`);
neither is pickled.
"""

from __future__ import annotations

import copy
import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np

from objectives.attitude import deployment as _deployment
from objectives.attitude.catalog import METRICS
from objectives.attitude.cexport import hooks as _c_hooks
from objectives.attitude.data.plausibility import motion_start, unit_warnings
from objectives.attitude.data.recording import Recording, RecordingError
from objectives.attitude.data_specs import check_specs as _check_specs
from objectives.attitude.data_specs import split_data as _split_data
from objectives.attitude.divergence import recording_failure, unbounded_growth
from objectives.attitude.fused_errors import error_sums
from objectives.attitude.metrics import euler_lock_warning, remove_heading_offset
from objectives.attitude.objective_options import (
    AGG_KEYS,
    ERROR_KEYS,
    RECORDING_KEYS,
    aggregate_scores,
    check_metric_options,
    check_prior,
    ungrouped_if_missing,
)
from objectives.attitude.prepared import DataSplit, Prepared, Split, check_split, prepare
from tuner.deployment import Deployment
from tuner.objective import Evaluation, Score
from tuner.space import Real, Space

__all__ = ["FilterObjective", "METRICS", "unit_warnings"]

#: the metrics of BROAD's total, heading and inclination error angles, mean over recordings (that order)
_BROAD_ANGLES = ("broad_mean_rmse", "heading_rmse_mean", "inclination_rmse_mean")
_KEYS = ("kind", "filter", "fixed", "data", "metric", "metric_options", "prior", "q0", "warmup_s", "report")


@dataclass
class FilterObjective:
    """Picklable objective scoring a filter's parameters on recordings (see module docstring)."""

    filter: str
    train_specs: list
    test_specs: list = field(default_factory=list)
    fixed: dict = field(default_factory=dict)
    metric: str = "euler_mse_geomean"
    metric_options: dict = field(default_factory=dict)
    q0: Any = "accmag"
    warmup_s: float = 0.0
    report: dict = field(default_factory=dict)
    base_dir: str = "."
    prior: dict = field(default_factory=dict)

    def __post_init__(self) -> None:
        from objectives.attitude.filters import get_filter

        self._cls = get_filter(self.filter)
        if self.metric not in METRICS:
            raise ValueError(f"objective.metric: unknown metric {self.metric!r}; allowed: {list(METRICS)}")
        unknown = sorted(set(self.fixed) - set(self._cls.defaults))
        if unknown:
            raise ValueError(f"objective.fixed.{unknown[0]}: not a parameter of {self.filter}; "
                             f"known: {sorted(self._cls.defaults)}")
        bad = sorted(set(self.metric_options) - {"weights", "normalize", *AGG_KEYS, *ERROR_KEYS})
        if bad:
            raise ValueError(f"objective.metric_options.{bad[0]}: unknown; allowed: weights, normalize, "
                             + ", ".join((*AGG_KEYS, *ERROR_KEYS)))
        check_metric_options(self.metric, self.metric_options)
        self.prior = check_prior(self.prior, list(self._cls.defaults))
        w = self.metric_options.get("weights", (1.0, 1.0, 1.0))
        if len(w) != 3 or any(not isinstance(x, (int, float)) or x < 0 for x in w):
            raise ValueError(f"objective.metric_options.weights: expected 3 numbers >= 0, got {w!r}")
        if not (isinstance(self.q0, str) and self.q0 in ("accmag", "truth", "broad")):
            q = np.zeros(0) if isinstance(self.q0, str) else np.asarray(self.q0, float)  # 'up': a misspelt name
            if q.shape != (4,) or not np.all(np.isfinite(q)) or not np.any(q):
                raise ValueError(f"objective.q0: expected accmag, truth, broad or 4 finite numbers (w, x, y, z), "
                                 f"not all 0, got {self.q0!r}")
        if self.warmup_s < 0:
            raise ValueError(f"objective.warmup_s: must be >= 0, got {self.warmup_s}")
        self._data = DataSplit()
        self._prepared: dict[Split, Prepared] = {}
        self._notes: list[str] = []  # what with_data found about its data (the preflight's first warnings)

    # --- construction -------------------------------------------------------------------------
    @classmethod
    def from_config(cls, section: Mapping[str, Any], base_dir: Path | None = None) -> FilterObjective:
        unknown = sorted(set(section) - set(_KEYS))
        if unknown:
            raise ValueError(f"objective.{unknown[0]}: unknown key; allowed: {sorted(_KEYS)}")
        if "filter" not in section:
            from objectives.attitude.filters import filter_names

            raise ValueError(f"objective.filter: missing; one of {filter_names()}")
        if "data" not in section:
            raise ValueError("objective.data: missing; a list of data specs or {train, test}")
        base = Path(base_dir) if base_dir else Path.cwd()
        train, test = _split_data(section["data"])
        if train and isinstance(train[0], tuple):  # k-fold
            _, items, k, fold = train[0]
            if not 2 <= k <= len(items) or not 0 <= fold < k:
                raise ValueError(f"objective.data.kfold: need 2 <= k <= {len(items)} and 0 <= fold < k, "
                                 f"got k={k}, fold={fold}")
            _check_specs(items, base, "objective.data.all")
            train = [("kfold-train", items, k, fold)]
            test = [("kfold-test", items, k, fold)]
        else:
            _check_specs(train, base, "objective.data.train" if test else "objective.data")
            _check_specs(test, base, "objective.data.test")
        fixed = section.get("fixed") or {}
        if not isinstance(fixed, Mapping):
            raise ValueError(f"objective.fixed: expected a mapping, got {fixed!r}")
        from objectives.attitude.filters import get_filter

        try:
            get_filter(section["filter"])
        except ValueError as exc:
            raise ValueError(f"objective.filter: {exc}") from None
        warmup = section.get("warmup_s", 0.0)
        if isinstance(warmup, bool) or not isinstance(warmup, (int, float)):
            raise ValueError(f"objective.warmup_s: expected a number of seconds >= 0, got {warmup!r}")
        return cls(
            filter=section["filter"], train_specs=train, test_specs=test, fixed=dict(fixed),
            metric=section.get("metric", "euler_mse_geomean"),
            metric_options=dict(section.get("metric_options") or {}),
            q0=section.get("q0", "accmag"), warmup_s=float(warmup),
            report=dict(section.get("report") or {}), base_dir=str(base), prior=section.get("prior") or {},
        )

    @classmethod
    def catalog(cls) -> dict[str, list[str]]:
        """Names ``objective.filter``, ``objective.metric`` and data specs accept (``tuner list``)."""
        from objectives.attitude.catalog import data_sources
        from objectives.attitude.filters import filter_names

        return {"filters": filter_names(), "metrics": list(METRICS), "data": list(data_sources())}

    @classmethod
    def explain(cls, name: str) -> dict[str, Any] | None:
        """``tuner describe NAME``: a filter, metric or data source (see :mod:`objectives.attitude.catalog`)."""
        from objectives.attitude.catalog import explain

        return explain(name)

    def with_data(self, data: Any) -> FilterObjective:
        """The same objective on other data (``tuner evaluate --data``): all of it is 'train'."""
        train, test = _split_data(data)
        specs = train + test
        _check_specs(specs, Path(self.base_dir), "data")
        out = FilterObjective(self.filter, specs, [], dict(self.fixed), self.metric, dict(self.metric_options),
                              self.q0, self.warmup_s, dict(self.report), self.base_dir, dict(self.prior))
        if self.metric_options.get("group_balanced"):  # recordings without the run's groups score ungrouped
            out.metric_options, out._notes = ungrouped_if_missing(out.metric_options, out.recordings("train"))
        return out

    def with_recordings(self, *, train: Iterable[Recording] | None = None,
                        test: Iterable[Recording] | None = None) -> FilterObjective:
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

    # --- engine hooks (tuner.objective.TunableObjective) ---------------------------------------
    def default_params(self) -> dict[str, Any]:
        """The filter's default values with ``fixed`` applied."""
        return {**self._cls.defaults, **self.fixed}

    def parameter_names(self) -> list[str]:
        """Every value the filter takes (searched or not)."""
        return sorted(self._cls.defaults)

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

    def describe(self) -> dict[str, Any]:
        """Provenance for ``tuner export``: filter, metric and the data specs."""
        def specs(lst):
            out = []
            for spec in lst:
                if isinstance(spec, tuple) and spec[0] == "subset":  # a CV fold or a held-out selection part
                    return {"all": specs(list(spec[1])), "subset": sorted(spec[2])}
                if isinstance(spec, tuple):
                    return {"all": spec[1], "kfold": {"k": spec[2], "fold": spec[3]}}
                out.append(spec)
            return out

        data = specs(self.train_specs)
        if self.test_specs and not isinstance(data, dict):
            data = {"train": data, "test": specs(self.test_specs)}
        return {"objective": {"kind": "filter", "filter": self.filter, "metric": self.metric}, "data": data}

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

    # --- search space ------------------------------------------------------------------------
    def default_space(self) -> Space:
        """The filter's default space with the ``fixed`` values pinned."""
        space_fn = self._cls.space
        tune_fuzzy = self.fixed.get("tune_fuzzy")
        try:
            base = space_fn(tune_fuzzy=tune_fuzzy) if tune_fuzzy is not None else space_fn()
        except TypeError:
            base = space_fn()
        params = []
        for p in base.params:
            params.append(Real(p.name, fixed=self.fixed[p.name], unit=p.unit, doc=p.doc)
                          if p.name in self.fixed else p)
        return Space(params)

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

    # --- scoring ------------------------------------------------------------------------------
    def check_params(self, params: Mapping[str, Any]) -> None:
        """The filter's own validation of ``params`` (with ``fixed``), nothing run (preflight's bound check)."""
        self.make_filter(params)

    def make_filter(self, params: Mapping[str, Any]):
        values = {**self.fixed, **{k: v for k, v in params.items() if k in self._cls.defaults}}
        return self._cls(**values)

    def _run(self, flt, rec: Recording, idx: tuple[Split, int]):
        """``flt`` on ``rec``, recording ``idx[1]`` of split ``idx[0]``, with its prepared disturbance inputs."""
        if callable(getattr(flt, "disturbances", None)):  # fuzzy inputs depend only on fixed window options
            return flt.run_detailed(rec, self.q0, disturbances=self.prepare(idx[0]).disturbances(flt, idx[1]))
        return flt.run_detailed(rec, self.q0)

    def _mask(self, rec: Recording) -> np.ndarray:
        mask = rec.motion.copy()
        if self.warmup_s > 0:
            mask[: int(round(self.warmup_s / rec.dt))] = False
        return mask

    def score(self, params: Mapping[str, Any], split: Split = "train", keep_outputs: bool = False,
              outputs_limit: int | None = None, filter_override: Any = None) -> Score:
        """Fitness and per-recording metrics of ``params`` on the train or test recordings.

        ``Score.recordings`` is ``{name: {metric: value}}``; with ``keep_outputs`` ``Score.outputs`` is
        ``{name: FilterResult}``, for the first ``outputs_limit`` recordings only when it is given (a report that
        draws one recording need not hold all sixteen BROAD trials); ``filter_override``: a filter scored instead.
        """
        recs = self.prepare(split).recordings
        if not recs:
            return Score(math.nan)
        flt = self.make_filter(params) if filter_override is None else filter_override
        per: dict[str, dict[str, float]] = {}
        outputs: dict[str, Any] = {}
        sums: list[Any] = []
        failed = ""
        for i, rec in enumerate(recs):
            res = self._run(flt, rec, (split, i))
            q = res.quat
            mask = self._mask(rec)
            m: dict[str, float] = {}
            if rec.quat is not None:
                truth = remove_heading_offset(q, rec.quat, mask) if self.metric_options.get("heading_offset") == \
                    "remove" else rec.quat
                es = error_sums(q, truth, mask)
                failed = recording_failure(rec.name, es, failed, partial(unbounded_growth, q, truth, mask))
                m.update(es.as_dict())
                sums.append(es)
            elif not np.isfinite(q).all() and not failed:
                failed = f"filter diverged on {rec.name}: non-finite output"
            if self.metric == "mse_1d":
                m["mse_1d"] = self._mse_1d(rec, res, mask)
            per[rec.name] = m
            if keep_outputs and (outputs_limit is None or len(outputs) < outputs_limit):
                outputs[rec.name] = res
        fitness = self._combine(sums, per, [r.name for r in recs], split)
        return Score(float(fitness), per, failed, outputs)

    @staticmethod
    def _mse_1d(rec: Recording, res: Any, mask: np.ndarray) -> float:
        from objectives.attitude import metrics as M
        from objectives.attitude.quaternion import euler_zyx

        est = res.diagnostics.get("angle")
        true = rec.extra.get("angle")
        if est is None:
            est = euler_zyx(res.quat)[:, 1]
        if true is None:
            if rec.quat is None:
                raise ValueError(f"{rec.name}: mse_1d needs extra['angle'] or truth quaternions")
            true = euler_zyx(rec.quat)[:, 1]
        return M.mse_1d(est, true, mask)

    def _combine(self, sums: list[Any], per: dict[str, dict[str, float]], names: list[str] | None = None,
                 split: Split = "train") -> float:
        """The configured metric from the per-recording sums (definitions in the module docstring)."""
        opts = self.metric_options
        if opts.get("aggregate", "mean") != "mean" or opts.get("group_balanced", False):
            key = RECORDING_KEYS.get(self.metric)
            names = list(per) if names is None else names
            scores = ([per[n][key] for n in names] if key else [float(np.mean(s.rmse_deg)) for s in sums])
            groups = self.prepare(split).group_map() if opts.get("group_balanced", False) else None
            return aggregate_scores(scores, names, opts, groups)
        if self.metric == "mse_1d":
            return float(np.mean([m["mse_1d"] for m in per.values()]))
        if not sums:
            raise ValueError(f"metric {self.metric} needs truth quaternions in the recordings")
        if self.metric == "euler_mse_geomean":  # eq. 35, as metrics.euler_mse_geomean
            w = np.asarray(self.metric_options.get("weights", (1.0, 1.0, 1.0)), float)
            with np.errstate(divide="ignore"):
                log_sum = sum(float(np.sum(np.where(w > 0, w * np.log(s.mse_rad2), 0.0))) for s in sums)
            root = w.sum() * (len(sums) if self.metric_options.get("normalize", False) else 1)
            return float(np.exp(log_sum / root))
        if self.metric == "euler_rmse_mean":
            return float(np.mean([np.mean(s.rmse_deg) for s in sums]))
        if self.metric in _BROAD_ANGLES:  # broad_mean_rmse, heading_rmse_mean, inclination_rmse_mean
            return float(np.mean([s.broad_rmse_deg[_BROAD_ANGLES.index(self.metric)] for s in sums]))
        total = sum(s.broad_ms_rad2[0] * s.n for s in sums) / sum(s.n for s in sums)
        return float(np.degrees(np.sqrt(total)))

    def prior_penalty(self, params: Mapping[str, Any]) -> float:
        """The ``prior`` penalty of ``params`` (0 without a prior), in the fitness's units."""
        if not self.prior or self.prior["strength"] == 0:
            return 0.0
        from objectives.attitude.aggregate import prior_penalty

        center = self.prior["center"]
        center = self.default_params() if center == "defaults" else {**self.default_params(), **center}
        space = self.default_space()
        full = {**self.default_params(), **params}
        for p in space.free:  # a log-scaled value <= 0 (an integral gain off) sits on the lower bound
            if p.scale == "log" and float(full[p.name]) <= 0:
                full[p.name] = p.low
        return prior_penalty(full, space, center, self.prior["strength"])

    def __call__(self, params: Mapping[str, Any]) -> Evaluation:
        return self._evaluation(params, self.score(params, "train"))

    def evaluate_batch(self, params_list: list[Mapping[str, Any]], n_threads: int) -> list[Any] | None:
        """A population in one numba kernel on ``n_threads`` threads, equal to ``[self(p) for p in
        params_list]`` (``backend: threads``); None where not batched (see objectives.attitude.batch)."""
        from objectives.attitude.batch import evaluate_batch

        return evaluate_batch(self, params_list, n_threads)

    def _evaluation(self, params: Mapping[str, Any], s: Score) -> Evaluation:
        """The evaluation of ``params`` from its train :class:`Score` (shared by the batch path)."""
        metrics = {}
        recs = s.recordings
        for name, m in recs.items():
            for k, v in m.items():
                metrics[f"{name}.{k}" if len(recs) > 1 else k] = v
        if s.failed:
            return Evaluation.failed(s.failed, metrics)
        if self.prior:
            pen = self.prior_penalty(params)
            metrics["prior_penalty"] = pen
            return Evaluation(s.fitness + pen, metrics)
        return Evaluation(s.fitness, metrics)

    # --- cross-validation (tuner cv) -----------------------------------------------------------------
    def cv_folds(self, k: int | None = None) -> list[tuple[str, FilterObjective, FilterObjective]]:
        """Folds over the objective's tuning recordings: ``(name, tune on, held out)``.

        ``test:`` recordings are never pooled into the folds: they keep their own held-out score, which
        the engine reports next to the CV score (:func:`tuner.cv.cross_validate`).

        Without ``k``, recordings that are all BROAD trials (a ``trials.json`` beside them) are grouped by
        BROAD's level-2 motion/disturbance group and each group is held out once (leave-one-group-out);
        otherwise, or with ``k``, recordings are assigned round-robin to ``k`` folds (default ``min(5, n)``).
        The tuning side keeps the objective's metric, options and prior; the held-out side keeps the metric
        without the aggregation options (each held-out recording counts once, as in the plain metric), and
        the engine scores it with ``score`` (no prior).
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
        if k is None:
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
                obj = FilterObjective(self.filter, [("subset", specs, tuple(keep))], [], dict(self.fixed),
                                      self.metric, opts, self.q0, self.warmup_s,
                                      dict(self.report), self.base_dir, dict(self.prior))
                sides.append(obj.with_recordings(train=[by_name[n] for n in keep]))
            out.append((fname, sides[0], sides[1]))
        return out

    def deployment(self, params: Mapping[str, Any]) -> Deployment:
        """The complete tuned filter: every value, scoring-only settings apart (objectives.attitude.deployment)."""
        return _deployment.filter_deployment(self, params)

    def build(self, params: Mapping[str, Any]):
        """The deployed filter instance of ``params`` (``.run(gyr, acc, mag, rate_hz=...)``, ``.stream()``)."""
        return _deployment.filter_build(self, params)

    export_c = _c_hooks.export_c_filter  # C99 of the deployed filter (tuner export --format c-source)
    verify_c = _c_hooks.verify_c_filter  # that C compiled and scored next to the model (tuner verify-c)

    # --- after the run ------------------------------------------------------------------------
    def finalize(self, run_dir: Path, best: Mapping[str, Any]) -> dict[str, Any]:
        """Train and test scores of the best parameters, a summary table and report figures."""
        from objectives.attitude.report import filter_report

        return filter_report(self, Path(run_dir), dict(best))
