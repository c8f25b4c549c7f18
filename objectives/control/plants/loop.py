"""The generic closed loop: any plant of the ``siso`` family (LTI models, Python dynamics, FMUs).

The loop of the ``siso`` family (:data:`objectives.control.plants.LOOPS`): the closed-loop objective
(:class:`objectives.control.objective.ClosedLoopObjective`) runs it when ``objective.plant`` is a mapping.

YAML (``objective:``; the plant's keys are its kind's, :mod:`.lti`, :mod:`.nonlinear`, :mod:`.fmu`; the
scenarios, actuator and sensor :mod:`.scenario`'s; cost and aggregation :mod:`.cost`'s; requirements
:mod:`.requirements`'; uncertainty :mod:`.uncertainty`'s)::

    kind: closed_loop
    plant: {tf: {num: [2.0], den: [0.5, 1.0]}, delay_s: 0.0}
    controller: pid2dof            # pid2dof | pid2dof_par | pid_cascade | lqr_sf | open_loop
    fixed: {N: 10, b: 1.0}         # controller values not searched
    period_s: 0.01                 # controller period (s)
    scenario: {duration_s: 5, reference: [{t: 0.5, value: 1}], load: [{t: 3, value: 0.2}]}
    # or scenarios: [{name: large, ...}, {name: small, ..., requirements: {...}, weight: 2}]
    actuator: {u_min: -12, u_max: 12}
    sensor: {noise_std: 0.0, seed: 0}
    cost: {iae: 1.0}
    aggregate: {scenarios: mean, models: worst}
    requirements: {max_overshoot_pct: 10, max_ms: 1.6}
    init: {rule: amigo, fit: area}  # optional: start from a tuning rule's PID (:mod:`.start`)
    uncertainty: {parameters: {"tf.num[0]": {rel: 0.2}}, tune: {samples: 4}, validate: {samples: 200}}

A candidate is scored on every (model, scenario) pair of its tuning set (the nominal plant alone
without ``uncertainty``) in one call of :class:`.batch.ItemRunner`; each pair's cost is aggregated over
the scenarios of a model, then over the models (:func:`.cost.combine`). An evaluation is
:class:`tuner.objective.Evaluation`: the cost and the metrics, with one scenario and one model every cost
term, the step, load and signal quantities, and for linear plants ``ms``, ``gm_db``, ``pm_deg`` and
``cl_pole_max`` (the largest |pole| of the linear closed loop: above 1 the loop is unstable and Ms is
inf); with several scenarios those of scenario ``s`` are ``s.<metric>`` (and ``s.cost``); over several
models a quantity is its worst model's, a cost term the models' mean, the margins the worst (and
``cost_model_mean``, ``cost_model_worst``). A diverging loop, a design without solution or a violated
requirement (on any model, in any scenario where it holds) is a failed evaluation with every reason;
a violation's fitness grows with how far the limits are missed (:func:`.requirements.violation`), so
an optimiser that has not yet found a feasible candidate is led towards one. The run report (the
requirements on the tuning set, small-signal and on held-out models) is :mod:`.report`'s.
"""

from __future__ import annotations

import math
import pathlib
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from objectives.control.design import failed_design
from objectives.control.plants.base import PlantKind
from objectives.control.plants.batch import ItemRunner
from objectives.control.plants.cost import aggregation_from_spec, combine, cost_from_spec, cost_of_stats
from objectives.control.plants.loop_yaml import LoopYaml
from objectives.control.plants.metrics import S_DONE, S_STATUS, row_metrics
from objectives.control.plants.modelset import MARGIN_KEYS, ModelSet, build_models
from objectives.control.plants.requirements import (
    REQUIREMENTS,
    check_limit,
    requirements_from_spec,
    violation,
)
from objectives.control.plants.scenario import cases_from_config, realism_from_spec
from objectives.control.plants.start import Start, init_from_spec, rule_start
from objectives.control.plants.uncertainty import check_largest_delay, draw_models, uncertainty_from_spec
from tuner.objective import PENALTY, Evaluation
from tuner.sizes import MAX_LOOP_SAMPLES, check_count

__all__ = ["SISOLoop", "DeployedController", "Scored"]

#: the loop's settings (the objective's keys besides kind, plant, controller, fixed)
_SETTINGS = ("period_s", "scenario", "scenarios", "actuator", "sensor", "cost", "aggregate", "requirements",
             "uncertainty", "init")
#: each requirement metric's scope (which scenarios define it)
_SCOPE = {r.metric: r.scope for r in REQUIREMENTS.values()}
#: the output and control limits a small-signal check lifts
_LIMIT_PARAMS = {"u_min": -math.inf, "u_max": math.inf, "r_i_min": -math.inf, "r_i_max": math.inf}


@dataclass(frozen=True)
class DeployedController:
    """A tuned loop controller: ``name``, every declared value, the period (s) and the coefficient array
    its discrete step runs (:mod:`.kernels`: PID blocks, or K and Nbar)."""

    name: str
    values: dict[str, Any]
    period_s: float
    coefficients: np.ndarray

    def param_array(self) -> np.ndarray:
        return self.coefficients


@dataclass(frozen=True)
class Scored:
    """A candidate on a model set: each item's quantities ``q[m][s]`` (requirement metrics), costs
    ``costs`` (M, S), each model's cost ``per_model`` (M,), the aggregate ``fitness``, each model's
    margins (linear plants; else empty) and the failure, if any (``error``, and the loop's ``status``:
    2 diverged, 3 a wrong shape)."""

    q: list[list[dict[str, float]]]
    terms: list[list[dict[str, float]]]
    costs: np.ndarray
    per_model: np.ndarray
    fitness: float
    margins: list[dict[str, float]]
    error: str = ""
    status: float = 0.0


class SISOLoop(LoopYaml):
    """The generic loop on one plant (and its model set) for one controller class (module docstring)."""

    family: ClassVar[str] = "siso"
    KEYS: ClassVar[frozenset[str]] = frozenset(_SETTINGS)
    MAPPINGS: ClassVar[tuple[str, ...]] = ("scenario", "actuator", "sensor", "requirements", "uncertainty", "cost")
    SECTIONS: ClassVar[tuple[str, ...]] = ("scenario", "actuator", "sensor", "cost", "requirements")
    OPTIONAL: ClassVar[tuple[str, ...]] = ("scenarios", "aggregate", "uncertainty", "init")
    DEFAULT_CONTROLLER: ClassVar[str] = "pid2dof"
    rate_name: ClassVar[str] = "controller period period_s"

    def __init__(self, kind: PlantKind, spec: Any, cls: Any, fixed: dict[str, Any], base_dir: Any = None,
                 period_s: Any = 0.01, scenario: Any = None, scenarios: Any = None, actuator: Any = None,
                 sensor: Any = None, cost: Any = None, aggregate: Any = None, requirements: Any = None,
                 uncertainty: Any = None, init: Any = None) -> None:
        p = period_s
        if isinstance(p, bool) or not isinstance(p, (int, float)) or not (math.isfinite(p) and p > 0):
            raise ValueError(f"objective.period_s: the controller period must be a number > 0 s, got {p!r}")
        self.kind, self.spec, self.controller, self.fixed, self.period = kind, dict(spec), cls.name, fixed, float(p)
        self.scenario, self.scenarios = dict(scenario or {}), scenarios
        self.actuator, self.sensor = dict(actuator or {}), dict(sensor or {})
        self.cost, self.aggregate = dict(cost or {}), aggregate
        self.requirements, self.uncertainty = dict(requirements or {}), uncertainty
        self.base_dir = pathlib.Path(base_dir) if base_dir else None
        self.plant = kind.build(self.spec, self.period, self.base_dir, "objective.plant")
        self.ctrl = cls
        if cls.needs_inner and self.plant.inner_output < 0:
            raise ValueError("objective.plant.inner_output: pid_cascade needs the inner loop's output index")
        self.decl = cls.declaration_for(self.plant)
        self.decl.validate(fixed)
        self._real = realism_from_spec(self.actuator, self.sensor)
        # the controller's output limits default to the actuator's: its anti-windup must see the saturation
        # (with infinite limits back-calculation and clamping never act), and the export carries them
        names = {q.name for q in self.decl}
        for k in ("u_min", "u_max"):
            lim = getattr(self._real, k)
            if k in names and k not in fixed and math.isfinite(lim):
                fixed[k] = lim
        self._cost = cost_from_spec(self.cost or None)
        self._agg = aggregation_from_spec(aggregate)
        self.linear = self.plant.linear
        job_req = requirements_from_spec(self.requirements, "objective.requirements")
        self._margin_req: dict[str, float] = {}
        for k, v in job_req.items():
            if REQUIREMENTS[k].scope == "margin":
                if not self.linear:
                    raise ValueError(f"objective.requirements.{k}: margins and Ms need an LTI plant (tf, zpk, ss)")
                self._margin_req[k] = check_limit(k, v, "objective.requirements")
        self.init = init
        self._init = init_from_spec(init, self._margin_req.get("max_ms"))
        self._start: Start | None = None
        if self._init is not None:
            if cls.from_ideal(1.0, 1.0, 0.0) is None:
                raise ValueError(f"objective.init: a rule gives one PID (pid2dof, pid2dof_par), not a {cls.name}")
            if self._init["max_ms"] is not None and not self.linear:
                raise ValueError("objective.init.max_ms: Ms needs an LTI plant (tf, zpk, ss); leave max_ms out")
        n_meas = self.plant.n_states if cls.name == "lqr_sf" else self.plant.n_outputs
        self.cases = cases_from_config(scenario, scenarios, self.period, n_meas, self._real, self._cost, job_req)
        self._weights = np.array([c.weight for c in self.cases])
        self._unc = uncertainty_from_spec(uncertainty, kind, self.spec, self.period)
        _check_work(self._unc, sum(c.signals.t.size for c in self.cases))
        if self._unc is not None:
            check_largest_delay(self._unc, kind, self.spec, self.period, self.base_dir)
        if self._unc is None:
            self.models = ModelSet("tuning", [self.plant], ["nominal"], [{}])
        else:
            self.models = build_models(kind, self.spec, draw_models(self._unc, "tuning", self.period), self.period,
                                       self.base_dir, "tuning", self._unc.seed, self.plant)
        self._runner = ItemRunner(self.models.plants, [c.sig for c in self.cases], [c.win for c in self.cases],
                                  cls.kind, self._real)
        self._heldout: ModelSet | None = None
        # the nominal model's first scenario, as the single-scenario loop had them
        self._sc, self._sig = self.cases[0].signals, self.cases[0].sig
        if self.linear:
            self._omega, prs = self.models.responses(states=cls.name == "lqr_sf")
            self._pr = prs[0]

    def settings(self) -> dict[str, Any]:
        """The settings this loop was built from (the objective pickles them)."""
        out = {"period_s": self.period, "scenario": self.scenario, "actuator": self.actuator, "sensor": self.sensor,
               "cost": self.cost, "requirements": self.requirements}
        for k in ("scenarios", "aggregate", "uncertainty", "init"):
            if getattr(self, k) is not None:
                out[k] = getattr(self, k)
        return out

    def start(self) -> Start | None:
        """The rule's PID of ``init`` (computed once: a step response, a fit and the detuning), or None."""
        if self._init is not None and self._start is None:
            def ms_of(pid: tuple[float, float, float]) -> float:
                return self.loop_margins(self.ctrl.from_ideal(*pid))["ms"]

            self._start = rule_start(self.plant, self._init, ms_of, float(self._sc.t[-1]))
        return self._start

    def start_values(self) -> dict[str, float]:
        """The controller's values of the ``init`` rule's PID (empty without ``init``)."""
        s = self.start()
        return {} if s is None else self.ctrl.from_ideal(*s.pid)

    # --- the objective's hooks -------------------------------------------------------------------
    @property
    def period_s(self) -> float:
        return self.period

    def describe(self) -> dict[str, Any]:
        data: dict[str, Any] = {"scenarios": [c.name for c in self.cases]} if self.scenarios is not None \
            else dict(self.scenario)
        if self._unc is not None:
            data["models"] = f"tuning set: {self.models.describe()}; held-out: {self._unc.validate_samples} models " \
                             f"(seed {self._unc.validate_seed})"
        return {"objective": {"kind": "closed_loop", "controller": self.controller, "plant": dict(self.spec),
                              "period_s": self.period}, "data": data}

    def scoring(self) -> dict[str, Any]:
        """The plant, scenarios, actuator, sensor, cost and requirements: they only serve scoring."""
        out = {"plant": self.spec, "scenario": self.scenario, "actuator": self.actuator, "sensor": self.sensor,
               "cost": self.cost, "requirements": self.requirements}
        for k in ("scenarios", "aggregate", "uncertainty"):
            if getattr(self, k) is not None:
                out[k] = getattr(self, k)
        return out

    def notes(self) -> list[str]:
        s = self.start()
        return [f"the controller runs every period_s = {self.period:g} s; its discrete coefficients are "
                "in the export's tables"] + ([f"the search started from {s.describe()}"] if s else [])

    def coeffs(self, params: Mapping[str, Any] | None) -> np.ndarray:
        """Kernel coefficients of ``params`` (with ``fixed`` and defaults); ValueError if not designable."""
        v = self.decl.validate({**self.fixed, **dict(params or {})})
        return self.ctrl.coeffs(v, self.plant)

    def linear_coeffs(self, params: Mapping[str, Any] | None) -> np.ndarray:
        """The coefficients of ``params`` with every output limit of the controller lifted (small signal)."""
        v = self.decl.validate({**self.fixed, **dict(params or {})})
        names = {q.name for q in self.decl}
        return self.ctrl.coeffs({**v, **{k: x for k, x in _LIMIT_PARAMS.items() if k in names}}, self.plant)

    def build(self, values: Mapping[str, Any]) -> DeployedController:
        """The deployed controller of ``values``: every value and the kernel coefficients at the period."""
        return DeployedController(self.controller, dict(values), self.period, self.ctrl.coeffs(values, self.plant))

    def export_tables(self, values: Mapping[str, Any]) -> dict[str, Any] | None:
        """The discrete controller for ``tuner export``: gains and difference-equation coefficients."""
        return self.ctrl.tables(self.coeffs(values), self.plant) or None

    # --- evaluation --------------------------------------------------------------------------------
    def simulate(self, params: Mapping[str, Any] | None = None, model: int = 0, scenario: int = 0) -> dict[str, Any]:
        """The response of ``params`` on one model (0: nominal) in one scenario: t, y (N, p), u (N, m),
        x (N, n), status, n_done (rows after a divergence are zero)."""
        return self._runner.trace(self.coeffs(params), model, scenario)

    def evaluate(self, params: Mapping[str, Any] | None = None) -> Evaluation:
        """The evaluation of ``params`` on the tuning set (module docstring)."""
        cp = self.coeffs(params)
        return self.evaluation_of(cp, self._runner.run(cp, 1)[0])

    def evaluate_batch(self, params_list: list[Mapping[str, Any]], n_threads: int) -> list[Any]:
        """A population on the tuning set in one kernel on ``n_threads`` threads (LTI models; stepped plants
        one item after the other), equal to ``[objective(p) for p in params_list]``."""
        out: list[Any] = [None] * len(params_list)
        cps, where = [], []
        for i, p in enumerate(params_list):
            try:
                cps.append(self.coeffs(p))
                where.append(i)
            except ValueError as exc:
                out[i] = failed_design(exc)
        if cps:
            stats = self._runner.run(np.array(cps), n_threads)
            for j, i in enumerate(where):
                out[i] = self.evaluation_of(cps[j], stats[j])
        return out

    def score(self, cp: np.ndarray, stats: np.ndarray, models: ModelSet) -> Scored:
        """The quantities, costs and margins of one candidate's statistics ``stats`` (M, S, row) on
        ``models``; ``error`` names a diverged loop."""
        n_m, n_s = stats.shape[:2]
        p, n = self.plant.n_outputs, self.plant.n_states
        for m in range(n_m):
            for s in range(n_s):
                st = stats[m, s, S_STATUS]
                if st != 0:
                    why = "returned a wrong shape" if st == 3 else "diverged"
                    where = (f" in scenario {self.cases[s].name}" if n_s > 1 else "") + \
                            (f" on model '{models.labels[m]}'" if n_m > 1 else "")
                    return Scored([], [], np.zeros((0, 0)), np.zeros(0), math.inf, [],
                                  f"closed loop {why} at t={stats[m, s, S_DONE] * self.period:.3g} s{where}",
                                  float(st))
        q, terms, costs = [], [], np.zeros((n_m, n_s))
        for m in range(n_m):
            qm, tm = [], []
            for s, case in enumerate(self.cases):
                t, means, quantities = row_metrics(stats[m, s], p, n)
                costs[m, s] = cost_of_stats(case.cost, t, means)
                qm.append(quantities)
                tm.append(t)
            q.append(qm)
            terms.append(tm)
        fitness, per_model = combine(costs, self._weights, self._agg)
        mg = models.margins(self.ctrl, cp) if models.linear else []
        return Scored(q, terms, costs, per_model, fitness, mg)

    def evaluation_of(self, cp: np.ndarray, stats: np.ndarray) -> Evaluation:
        """The :class:`~tuner.objective.Evaluation` of one candidate's statistics on the tuning set."""
        sc = self.score(cp, stats, self.models)
        if sc.error:
            return Evaluation.failed(sc.error, {"status_code": sc.status})
        m = self.metrics(sc)
        reasons, total = self.violations(sc, self.models)
        if reasons:
            return Evaluation(PENALTY * (1.0 + total), m, "failed", "; ".join(reasons))
        if not math.isfinite(sc.fitness):
            return Evaluation.failed(f"non-finite cost {sc.fitness}", m)
        return Evaluation(sc.fitness, m)

    def metrics(self, sc: Scored) -> dict[str, float]:
        """The metrics of a scored candidate (module docstring)."""
        n_m, n_s = sc.costs.shape
        m: dict[str, float] = {"status_code": 0.0}
        for s, case in enumerate(self.cases):
            pre = f"{case.name}." if n_s > 1 else ""
            for k in sc.terms[0][s]:
                m[pre + k] = float(np.mean([sc.terms[i][s][k] for i in range(n_m)])) if n_m > 1 else sc.terms[0][s][k]
            if n_s > 1:
                m[pre + "cost"] = float(np.mean(sc.costs[:, s]))
            for k, v in sc.q[0][s].items():
                if case.defines(_SCOPE.get(k, "signal")):
                    m[pre + k] = float(max(sc.q[i][s][k] for i in range(n_m))) if n_m > 1 else v
        for k in MARGIN_KEYS if sc.margins else ():
            vals = [mg[k] for mg in sc.margins]
            m[k] = float(min(vals) if k in ("gm_db", "pm_deg") else max(vals))
        if n_m > 1:
            m["cost_model_mean"] = float(np.mean(sc.per_model))
            m["cost_model_worst"] = float(np.max(sc.per_model))
        return m

    def check_keys(self) -> list[tuple[str, int | None]]:
        """``(requirement key, scenario index or None for a margin)`` of every check, in table order."""
        return [(k, s) for s, c in enumerate(self.cases) for k in c.limits] + [(k, None) for k in self._margin_req]

    def checks(self, sc: Scored) -> list[dict[str, Any]]:
        """Every requirement check of a scored candidate: ``{key, scenario (index or None), limit, values
        (one per model), met (per model)}``, margins last."""
        out = []
        for s, case in enumerate(self.cases):
            for key in case.limits:
                r = REQUIREMENTS[key]
                lim = case.effective_limit(key)
                vals = np.array([sc.q[i][s][r.metric] for i in range(len(sc.q))])
                out.append({"key": key, "scenario": s, "limit": lim, "values": vals, "met": _met(r.sense, vals, lim)})
        for key, lim in self._margin_req.items():
            r = REQUIREMENTS[key]
            vals = np.array([mg[r.metric] for mg in sc.margins])
            out.append({"key": key, "scenario": None, "limit": lim, "values": vals, "met": _met(r.sense, vals, lim)})
        return out

    def violations(self, sc: Scored, models: ModelSet) -> tuple[list[str], float]:
        """``(reasons, total)``: one text per violated requirement (its worst value, scenario and how many
        models miss it) and the sum of each one's worst :func:`~.requirements.violation`."""
        reasons, total = [], 0.0
        n_m, n_s = len(models), len(self.cases)
        for chk in self.checks(sc):
            if chk["met"].all():
                continue
            r = REQUIREMENTS[chk["key"]]
            vals = chk["values"]
            worst = math.nan if np.isnan(vals).any() else float(vals.max() if r.sense == "max" else vals.min())
            unit = "" if r.unit == "1" else f" {r.unit}"
            where = (f" in scenario {self.cases[chk['scenario']].name}" if chk["scenario"] is not None and n_s > 1
                     else "") + (f" on {int((~chk['met']).sum())} of {n_m} models" if n_m > 1 else "")
            reasons.append(f"requirement violated: {r.words} {worst:.4g}{unit} {'>' if r.sense == 'max' else '<'} "
                           f"{chk['limit']:.4g}{unit} ({chk['key']}){where}")
            total += violation(chk["key"], worst, chk["limit"])
        return reasons, total

    # --- model sets after the run ------------------------------------------------------------------
    def heldout(self) -> ModelSet | None:
        """The held-out model set of the ``uncertainty`` block (built on first use), or None."""
        if self._unc is None:
            return None
        if self._heldout is None:
            self._heldout = build_models(self.kind, self.spec, draw_models(self._unc, "held-out", self.period),
                                         self.period, self.base_dir, "held-out", self._unc.validate_seed)
        return self._heldout

    def runner(self, models: ModelSet, linear: bool = False) -> ItemRunner:
        """An item runner of ``models`` over the scenarios; ``linear``: without actuator limits, rate limit
        and quanta (the small-signal loop of :mod:`.robustness`; the same noise)."""
        from objectives.control.plants.scenario import Realism

        real = Realism(noise_std=self._real.noise_std, seed=self._real.seed) if linear else self._real
        return ItemRunner(models.plants, [c.sig for c in self.cases], [c.win for c in self.cases], self.ctrl.kind, real)

    @property
    def realism(self) -> Any:
        """The actuator and sensor options (:class:`~.scenario.Realism`)."""
        return self._real

    def export_c(self, values: Mapping[str, Any], precision: str, prefix: str, comment: str) -> dict[str, str]:
        """The controller of ``values`` as C99 (:mod:`.cexport`)."""
        from objectives.control.plants.cexport import export_c_controller

        return export_c_controller(self, dict(values), precision, prefix, comment)

    def verify_c(self, values: Mapping[str, Any], precision: str, opt: tuple[str, ...]) -> dict[str, Any]:
        """That C compiled and its loop closed next to the kernel's (:mod:`.cexport`)."""
        from objectives.control.plants.cexport import verify_c_controller

        return verify_c_controller(self, dict(values), precision, opt)

    @property
    def uncertainty_block(self) -> Any:
        """The parsed ``uncertainty`` block (:class:`~.uncertainty.Uncertainty`) or None."""
        return self._unc

    # --- report ------------------------------------------------------------------------------------
    def loop_margins(self, params: Mapping[str, Any] | None) -> dict[str, float]:
        """``ms``, ``gm_db``, ``pm_deg``, ``cl_pole_max`` and the crossovers of the nominal model (linear plants)."""
        return ModelSet("nominal", [self.plant], ["nominal"]).margins(self.ctrl, self.coeffs(params))[0]

    def traces(self, params: Mapping[str, Any]) -> dict[str, dict[str, Any]]:
        s = self.simulate(params)
        return {"output y": {"t": self._sc.t, "y": s["y"][:, self.plant.output], "ref": self._sc.r},
                "control u": {"t": self._sc.t, "y": s["u"][:, 0], "ref": None}}

    def finalize(self, run_dir: pathlib.Path, init: dict[str, Any], best: dict[str, Any]) -> dict[str, Any]:
        """Responses (defaults and tuned, every scenario), for linear plants a Bode plot with the margins, and
        ``requirements.md`` (tuning set, small signal, held-out models); returns the scores of both."""
        from objectives.control.plants.report import write_report

        return write_report(self, run_dir, init, best)


def _met(sense: str, vals: np.ndarray, lim: float) -> np.ndarray:
    """Per value whether it meets ``lim`` (NaN never does)."""
    with np.errstate(invalid="ignore"):
        return vals <= lim if sense == "max" else vals >= lim


def _check_work(unc: Any, n_samples: int) -> None:
    """Models x samples of all scenarios, for the tuning set (every evaluation) and the held-out set (scored
    once after the run), against :data:`tuner.sizes.MAX_LOOP_SAMPLES`, before any model is built."""
    if unc is None:  # one model: the scenarios' samples are bounded by tuner.sizes.MAX_SAMPLES already
        return
    for key, name, n_models in (("objective.uncertainty.tune.samples", "the tuning set", unc.tuning_size()),
                                ("objective.uncertainty.validate.samples", "the held-out set", unc.validate_samples)):
        check_count(key, n_models * n_samples, MAX_LOOP_SAMPLES,
                    f"one pass of {name} over the scenarios in sample steps ({n_models:,} models x {n_samples:,} "
                    "samples of all scenarios)", "fewer models, shorter scenarios or a longer period_s")
