"""The MuJoCo loop: controllers of the ``mujoco`` family tuned on a MuJoCo model, over one or many models.

The loop of the ``mujoco`` family (:data:`objectives.control.plants.LOOPS`), run by the closed-loop objective
for ``plant: {mujoco: ...}``. YAML (``objective:``)::

    kind: closed_loop
    plant: {mujoco: cartpole.xml, keyframe: upright, outputs: [cart, hinge], state_joints: [slider, hinge]}
    controller: lqr_fd             # lqr_fd | joint_pid
    fixed: {r_push: 0.1}
    period_s: 0.002                # a whole number of the model's timestep
    scenario: {duration_s: 5, reference: {cart: [{t: 1, value: 0.5}]}, initial: {hinge: 0.1},
               limits: {hinge: 0.8}}
    sensor: {noise_std: 0.0, delay_s: 0.0, seed: 0}
    cost: {iae: 1.0, effort: 0.001}
    requirements: {max_overshoot_pct: 20, max_settling_time_s: 3}
    uncertainty: {parameters: {body.pole.mass: {rel: 0.2}}, tune: {samples: 8}, validate: {samples: 100}}
    aggregate: {models: mean}      # the cost over the tuning models: mean | worst | {cvar: alpha}

The plant's keys are :mod:`.model`'s, the scenario's, sensor's and cost's :mod:`.scenario`'s, the
uncertainty's :mod:`.uncertainty`'s; requirements are the generic loop's step and actuator requirements
(``max_overshoot_pct``, ``max_rise_time_s``, ``max_settling_time_s``, ``max_ss_error``, ``max_peak_u``; no
margins: the plant is not linear), met by the worst output on every tuning model.

An evaluation runs the candidate on every model of the tuning set (the nominal model alone without
``uncertainty``): each run is one compiled loop (:mod:`.kernel`); the cost is the models' aggregate
(``aggregate: {models: ...}``: mean, worst or CVaR, the generic loop's forms); a run that diverged, left its
limits or that MuJoCo warned about, or a violated requirement on any model, fails the evaluation with the model
and the reason. ``backend: threads`` runs a generation's (candidate, model) runs on threads (:mod:`.batch`),
equal to the serial evaluations. The run report (:mod:`.report`) adds the held-out models' pass rates.
"""

from __future__ import annotations

import math
import pathlib
from collections.abc import Mapping
from typing import Any, ClassVar

import numpy as np

from objectives.control.plants.base import PlantKind
from objectives.control.plants.loop import DeployedController
from objectives.control.plants.loop_yaml import LoopYaml
from objectives.control.plants.mujoco.kernel import STATUS_DIVERGED, STATUS_LIMIT, STATUS_OK
from objectives.control.plants.mujoco.scenario import (
    cost_for,
    loop_cost,
    measurement_for,
    scenario_for,
    step_table,
)
from objectives.control.plants.mujoco.steps import first_step, requirements_for, violated
from objectives.control.plants.mujoco.uncertainty import (
    ModelCase,
    aggregation_from_spec,
    over_models,
    uncertainty_from_spec,
)
from objectives.control.plants.requirements import REQUIREMENTS
from tuner.objective import Evaluation

__all__ = ["MujocoLoop"]

_SETTINGS = ("period_s", "scenario", "sensor", "cost", "requirements", "uncertainty", "aggregate")


class MujocoLoop(LoopYaml):
    """The loop on a MuJoCo plant for one controller class (module docstring); built by the objective."""

    family: ClassVar[str] = "mujoco"
    KEYS: ClassVar[frozenset[str]] = frozenset(_SETTINGS)
    MAPPINGS: ClassVar[tuple[str, ...]] = ("scenario", "sensor", "cost", "requirements", "uncertainty")
    SECTIONS: ClassVar[tuple[str, ...]] = ("scenario", "sensor", "cost", "requirements")
    OPTIONAL: ClassVar[tuple[str, ...]] = ("uncertainty", "aggregate")
    WHAT: ClassVar[str] = "a MuJoCo plant"
    DEFAULT_CONTROLLER: ClassVar[str] = "joint_pid"
    rate_name: ClassVar[str] = "controller period period_s"

    def __init__(self, kind: PlantKind, spec: Any, cls: Any, fixed: dict[str, Any], base_dir: Any = None,
                 period_s: Any = 0.01, scenario: Any = None, sensor: Any = None, cost: Any = None,
                 requirements: Any = None, uncertainty: Any = None, aggregate: Any = None) -> None:
        p = period_s
        if isinstance(p, bool) or not isinstance(p, (int, float)) or not (math.isfinite(p) and p > 0):
            raise ValueError(f"objective.period_s: the controller period must be a number > 0 s, got {p!r}")
        self.spec, self.controller, self.fixed, self.period = dict(spec), cls.name, fixed, float(p)
        self.scenario, self.sensor, self.cost = dict(scenario or {}), dict(sensor or {}), dict(cost or {})
        self.requirements = dict(requirements or {})
        self.uncertainty = dict(uncertainty) if uncertainty is not None else None
        self.aggregate = aggregate
        self._agg = aggregation_from_spec(aggregate)
        self.plant = kind.build(self.spec, self.period, pathlib.Path(base_dir) if base_dir else None,
                                "objective.plant")
        self.ctrl = cls
        try:
            self.decl = cls.declaration_for(self.plant)
        except ValueError as exc:
            raise ValueError(f"objective.controller: {exc}") from None
        self.decl.validate(fixed)
        plant = self.plant
        self._sc = scenario_for(plant, self.scenario, self.period)
        names = plant.state_names if cls.state_feedback else plant.output_names
        self._meas = measurement_for(self.sensor, list(names), self.period)
        self._terms, self._weights = cost_for(self.cost, plant.output_names)
        wins = [first_step(self._sc.output_scenario(i).r) for i in self._sc.tracked]
        wins = [w for w in wins if w is not None]
        window = min(((k1 - k0) * self.period for k0, k1 in wins), default=math.inf)
        self._req = requirements_for(self.requirements, bool(wins), window)
        if cls.state_feedback:
            self._check_set_points()
        self._unc = uncertainty_from_spec(self.uncertainty, plant, self._meas.delay_n(self.period), self.period)
        self.cases = self._unc.tuning_set() if self._unc else [ModelCase("nominal", {}, self._meas.delay_n(self.period),
                                                                          1.0)]
        self.plants = [self.model_plant(c) for c in self.cases]
        self._noise = self._meas.noise(self._sc.t.size)
        self._datas: list[Any] = [None] * len(self.cases)
        #: the held-out models' plants, built on first use by the report (:func:`.report.held_out_scores`)
        self._held_plants: list[Any] | None = None

    def _check_set_points(self) -> None:
        """State feedback reaches a set point only of a position or velocity in the state, and only where the
        linearisation has a steady state there: an error up front otherwise."""
        from objectives.control.plants.mujoco.controllers import set_point_gains

        names = self.plant.output_names
        rows = []
        for i in self._sc.tracked:
            try:
                rows.append(self.plant.state_row(i))
            except ValueError as exc:
                raise ValueError(f"objective.scenario.reference.{names[i]}: {self.controller} follows set points of "
                                 f"state entries only: {exc}") from None
        if rows:
            ad, bd = self.plant.design_model()
            _, _, res = set_point_gains(ad, bd, np.array(rows))
            if not res < 1e-6:
                which = [names[i] for i in self._sc.tracked]
                raise ValueError(f"objective.scenario.reference: no steady state of the linearised plant holds "
                                 f"{which} at a set point (residual {res:.3g}); give references only to outputs "
                                 "the plant can hold (a cart's position, not a pendulum's angle)")

    def model_plant(self, case: ModelCase) -> Any:
        """The plant of one model (the nominal plant itself when nothing is perturbed)."""
        return self.plant.with_parameters(case.values, "objective.uncertainty") if case.values else self.plant

    def settings(self) -> dict[str, Any]:
        return {"period_s": self.period, "scenario": self.scenario, "sensor": self.sensor, "cost": self.cost,
                "requirements": self.requirements, "uncertainty": self.uncertainty,
                **({"aggregate": self.aggregate} if self.aggregate is not None else {})}

    # --- the objective's hooks -------------------------------------------------------------------
    @property
    def period_s(self) -> float:
        return self.period

    def describe(self) -> dict[str, Any]:
        return {"objective": {"kind": "closed_loop", "controller": self.controller, "plant": dict(self.spec),
                              "period_s": self.period}, "data": self.scenario}

    def scoring(self) -> dict[str, Any]:
        """The plant, scenario, sensor, cost, requirements and uncertainty: they only serve scoring."""
        return {"plant": self.spec, "scenario": self.scenario, "sensor": self.sensor, "cost": self.cost,
                "requirements": self.requirements, "uncertainty": self.uncertainty,
                **({"aggregate": self.aggregate} if self.aggregate is not None else {})}

    def notes(self) -> list[str]:
        p = self.plant
        out = [f"the controller runs every period_s = {self.period:g} s ({p.n_sub} MuJoCo steps of "
               f"{p.timestep_s:g} s); inputs {p.input_names}, measured {list(self._meas.names)}"]
        if self._unc is not None:
            out.append(self._unc.summary())
        return out

    def values(self, params: Mapping[str, Any] | None) -> dict[str, Any]:
        return self.decl.validate({**self.fixed, **dict(params or {})})

    def coeffs(self, params: Mapping[str, Any] | None) -> np.ndarray:
        """Kernel coefficients of ``params`` (with ``fixed`` and defaults); ``ValueError`` if not designable."""
        return np.ascontiguousarray(self.ctrl.coeffs(self.values(params), self.plant, self._sc.tracked))

    def build(self, values: Mapping[str, Any]) -> DeployedController:
        return DeployedController(self.controller, dict(values), self.period,
                                  self.ctrl.coeffs(values, self.plant, self._sc.tracked))

    def export_tables(self, values: Mapping[str, Any]) -> dict[str, Any] | None:
        return self.ctrl.tables(self.coeffs(values), self.plant) or None

    # --- evaluation --------------------------------------------------------------------------------
    def signals(self, case: ModelCase) -> np.ndarray:
        """The kernel's ``sig`` of one model: the references, then the noise scaled by the model's factor."""
        return np.ascontiguousarray(np.column_stack([self._sc.r, self._noise * case.noise_scale]))

    def run_case(self, cp: np.ndarray, j: int, data: Any, plant: Any = None, case: ModelCase | None = None,
                 sig: np.ndarray | None = None) -> dict[str, Any]:
        """One run of coefficients ``cp`` on model ``j`` of the tuning set (or on ``plant``/``case`` given)
        in the ``mjData`` ``data`` of that plant: y (N, p), u (N, m), x (N, n), status, n_done, warning."""
        plant = self.plants[j] if plant is None else plant
        case = self.cases[j] if case is None else case
        n = self._sc.t.size
        y, u, x = np.zeros((n, plant.n_outputs)), np.zeros((n, plant.n_inputs)), np.zeros((n, plant.n_states))
        plant.reset_data(data, self._sc.qpos_offset, self._sc.qvel_offset)
        opt = plant.options(self.ctrl.kind, case.delay_n)
        status, done, warned = plant.run(data, self.signals(case) if sig is None else sig, cp, opt, self._sc.ylim,
                                         y, u, x)
        return {"y": y, "u": u, "x": x, "status": status, "n_done": done, "warning": warned}

    def _data(self, j: int) -> Any:
        if self._datas[j] is None:
            self._datas[j] = self.plants[j].new_data()
        return self._datas[j]

    def simulate(self, params: Mapping[str, Any] | None = None) -> dict[str, Any]:
        """The closed loop of ``params`` on every tuning model: t, r and ``runs`` (one dict of
        :meth:`run_case` per model, the nominal first)."""
        cp = self.coeffs(params)
        runs = [self.run_case(cp, j, self._data(j)) for j in range(len(self.cases))]
        return {"t": self._sc.t, "r": self._sc.r, "runs": runs}

    def start_values(self) -> dict[str, Any]:
        """No tuning rule starts a MuJoCo loop's controllers: the declaration's defaults are the start."""
        return {}

    def evaluate(self, params: Mapping[str, Any] | None = None) -> Evaluation:
        """The evaluation of ``params`` on the tuning set (``ValueError`` when the design cannot be built)."""
        return self.evaluation(self.simulate(params), params)

    def evaluate_batch(self, params_list: list[Mapping[str, Any]], n_threads: int) -> list[Any]:
        """A generation's runs on ``n_threads`` threads (:mod:`.batch`), equal to the serial evaluations."""
        from objectives.control.plants.mujoco.batch import evaluate_batch

        return evaluate_batch(self, params_list, n_threads)

    def run_metrics(self, run: Mapping[str, Any]) -> tuple[float, dict[str, float], str]:
        """``(cost, metrics, why it failed or '')`` of one run."""
        h, n, plant = self.period, run["n_done"], self.plant
        m: dict[str, float] = {"status_code": float(run["status"])}
        if run["status"] != STATUS_OK:
            t = n * h
            if run["warning"]:
                why = f"MuJoCo: {run['warning']} (t={t:.3g} s)"
            elif run["status"] == STATUS_LIMIT:
                y = run["y"][n - 1]
                bad = [plant.output_names[i] for i in range(plant.n_outputs) if abs(y[i]) > self._sc.ylim[i]]
                why = f"{', '.join(bad)} beyond its limit at t={t:.3g} s"
            else:
                why = f"closed loop {'diverged' if run['status'] == STATUS_DIVERGED else 'failed'} at t={t:.3g} s"
            return math.nan, m, why
        y, u = run["y"], run["u"]
        f, terms = loop_cost(self._terms, self._weights, self._sc.t, self._sc.r - y, u - plant.ctrl_op[plant.inp_adr],
                             h)
        m.update(terms)
        m.update(step_table(self._sc, y, h, plant.output_names))
        m["peak_u"] = float(np.max(np.abs(u))) if u.size else 0.0
        bad = violated(self._req, m)
        if bad:
            return f, m, f"requirement violated: {bad}"
        if not math.isfinite(f):
            return f, m, f"non-finite cost {f}"
        return f, m, ""

    def evaluation(self, sim: Mapping[str, Any], params: Mapping[str, Any] | None = None) -> Evaluation:
        """Score the runs of one candidate (module docstring): the aggregate cost, the nominal model's
        metrics and, over several models, the cost's mean and worst."""
        scored = [self.run_metrics(r) for r in sim["runs"]]
        failed = [(j, why) for j, (_, _, why) in enumerate(scored) if why]
        metrics = dict(scored[0][1])
        many = len(scored) > 1
        if failed:
            j, why = failed[0]
            where = f"{self.cases[j].label}: " if many else ""
            tail = f" (failed on {len(failed)} of {len(scored)} models)" if many else ""
            return Evaluation.failed(f"{where}{why}{tail}", metrics)
        costs = np.array([f for f, _, _ in scored])
        if many:
            metrics.update({"cost_mean": float(np.mean(costs)), "cost_worst": float(np.max(costs)),
                            "n_models": float(len(costs))})
            for r in REQUIREMENTS.values():  # the requirement metrics' worst over the models
                vals = [s[1].get(r.metric, math.nan) for s in scored]
                if all(math.isfinite(v) for v in vals):
                    metrics[r.metric] = max(vals) if r.sense == "max" else min(vals)
        return Evaluation(over_models(costs, self._agg), metrics)

    def requirement_rows(self, ev: Evaluation) -> list[dict[str, Any]]:
        """``[{requirement, what, limit, value, met}]`` of the evaluation ``ev``."""
        rows = []
        for key, lim in self._req.items():
            metric, sense, what = REQUIREMENTS[key].metric, REQUIREMENTS[key].sense, REQUIREMENTS[key].words
            v = ev.metrics.get(metric, math.nan)
            met = bool(v <= lim) if sense == "max" else bool(v >= lim)
            rows.append({"requirement": key, "what": what, "limit": lim, "value": v, "met": met})
        return rows

    # --- report ------------------------------------------------------------------------------------
    def traces(self, params: Mapping[str, Any]) -> dict[str, dict[str, Any]]:
        """Every output against its reference and every input, on the nominal model."""
        run = self.run_case(self.coeffs(params), 0, self._data(0))
        t, p = self._sc.t, self.plant
        out = {f"output {n}": {"t": t, "y": run["y"][:, i], "ref": self._sc.r[:, i]}
               for i, n in enumerate(p.output_names)}
        out.update({f"input {n}": {"t": t, "y": run["u"][:, i], "ref": None} for i, n in enumerate(p.input_names)})
        return out

    def finalize(self, run_dir: pathlib.Path, init: dict[str, Any], best: dict[str, Any]) -> dict[str, Any]:
        """Responses, requirements and (with ``uncertainty``) the held-out models (:mod:`.report`)."""
        from objectives.control.plants.mujoco.report import write_report

        return write_report(self, run_dir, init, best)
