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

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np

from objectives.attitude import fingerprint as _fingerprint
from objectives.attitude import ros_export as _ros_export
from objectives.attitude.catalog import METRICS
from objectives.attitude.cexport import hooks as _c_hooks
from objectives.attitude.data.plausibility import unit_warnings
from objectives.attitude.data.recording import Recording
from objectives.attitude.data_specs import check_specs as _check_specs
from objectives.attitude.data_specs import split_data as _split_data
from objectives.attitude.divergence import recording_failure, unbounded_growth
from objectives.attitude.fused_errors import error_sums
from objectives.attitude.metrics import remove_heading_offset
from objectives.attitude.objective_data import FilterData
from objectives.attitude.objective_options import (
    AGG_KEYS,
    ERROR_KEYS,
    RECORDING_KEYS,
    aggregate_scores,
    check_metric_options,
    check_prior,
)
from objectives.attitude.objective_report import FilterReporting
from objectives.attitude.prepared import DataSplit, Prepared, Split
from tuner.objective import Evaluation, Score
from tuner.space import Real, Space

__all__ = ["FilterObjective", "METRICS", "unit_warnings"]

#: the metrics of BROAD's total, heading and inclination error angles, mean over recordings (that order)
_BROAD_ANGLES = ("broad_mean_rmse", "heading_rmse_mean", "inclination_rmse_mean")
_KEYS = ("kind", "filter", "fixed", "data", "metric", "metric_options", "prior", "q0", "warmup_s", "report")


@dataclass
class FilterObjective(FilterData, FilterReporting):
    """Picklable objective scoring a filter's parameters on recordings (see module docstring).

    This class is the ``filter`` kind's entry point: construction and validation, the search space, scoring and
    the population batch; its data half (recordings, splits, preflight, folds) is :class:`FilterData`, its
    reporting half (catalog, provenance, deployment, report) :class:`FilterReporting`.
    """

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

    # --- engine hooks (tuner.objective.TunableObjective) ---------------------------------------
    def default_params(self) -> dict[str, Any]:
        """The filter's default values with ``fixed`` applied."""
        return {**self._cls.defaults, **self.fixed}

    def parameter_names(self) -> list[str]:
        """Every value the filter takes (searched or not)."""
        return sorted(self._cls.defaults)

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

    export_c = _c_hooks.export_c_filter  # C99 of the deployed filter (tuner export --format c-source)
    verify_c = _c_hooks.verify_c_filter  # that C compiled and scored next to the model (tuner verify-c)
    export_formats = _ros_export.export_formats  # the filter's own formats: its ROS node's parameter file
    export_as = _ros_export.export_as  # tuner export --format ros2-params | ros1-params

    def fingerprint(self) -> dict[str, Any]:
        """The tuning data's sensor statistics (:mod:`objectives.attitude.fingerprint`), stored by every run."""
        return _fingerprint.fingerprint(self.recordings("train"))

    def compare_fingerprint(self, stored: Mapping[str, Any] | None) -> str | None:
        """One warning line when this objective's data differs from ``stored`` beyond the thresholds."""
        return _fingerprint.compare(stored, self.fingerprint())
