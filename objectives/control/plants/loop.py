"""The generic closed loop: any plant of the ``siso`` family (LTI models, Python dynamics, FMUs).

The loop of the ``siso`` family (:data:`objectives.control.plants.LOOPS`): the closed-loop objective
(:class:`objectives.control.objective.ClosedLoopObjective`) runs it when ``objective.plant`` is a mapping.

YAML (``objective:``; the plant's keys are its kind's, :mod:`.lti`, :mod:`.nonlinear`, :mod:`.fmu`; the
rest :mod:`.scenario`'s)::

    kind: closed_loop
    plant: {tf: {num: [2.0], den: [0.5, 1.0]}, delay_s: 0.0}
    controller: pid2dof            # pid2dof | pid2dof_par | pid_cascade | lqr_sf | open_loop
    fixed: {N: 10, b: 1.0}         # controller values not searched
    period_s: 0.01                 # controller period (s)
    scenario: {duration_s: 5, reference: [{t: 0.5, value: 1}], load: [{t: 3, value: 0.2}]}
    actuator: {u_min: -12, u_max: 12}
    sensor: {noise_std: 0.0, seed: 0}
    cost: {iae: 1.0}
    requirements: {max_overshoot_pct: 10, max_ms: 1.6}
    init: {rule: amigo, fit: area}  # optional: start from a tuning rule's PID (:mod:`.start`)

An evaluation is :class:`tuner.objective.Evaluation`: the cost and the metrics (every cost term, the step
metrics, ``peak_u``, and for linear plants ``ms``, ``gm_db``, ``pm_deg`` and ``cl_pole_max``, the largest
|pole| of the linear closed loop: above 1 the loop is unstable and Ms is inf); a diverging loop, a design
without solution or a violated requirement is a failed evaluation with the reason. The noise is drawn once
from ``sensor.seed``: every candidate sees the same. The run report is :mod:`.report`'s.
"""

from __future__ import annotations

import math
import pathlib
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from objectives.control.plants.analysis import (
    closed_loop_poles,
    exact_loop,
    frequency_grid,
    loop_response,
    margins,
    plant_response,
)
from objectives.control.plants.base import PlantKind
from objectives.control.plants.scenario import (
    REQUIREMENTS,
    check_requirements,
    cost_from_spec,
    loop_cost,
    realism_from_spec,
    requirements_from_spec,
    scenario_from_spec,
    step_metrics,
)
from objectives.control.plants.simulate import simulate_loop
from objectives.control.plants.start import Start, init_from_spec, rule_start
from tuner.objective import Evaluation

__all__ = ["SISOLoop", "DeployedController"]

#: the loop's settings (the objective's keys besides kind, plant, controller, fixed)
_SETTINGS = ("period_s", "scenario", "actuator", "sensor", "cost", "requirements", "init")


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


class SISOLoop:
    """The generic loop on one plant for one controller class (module docstring); built by the objective."""

    family: ClassVar[str] = "siso"
    KEYS: ClassVar[frozenset[str]] = frozenset(_SETTINGS)
    DEFAULT_CONTROLLER: ClassVar[str] = "pid2dof"
    rate_name: ClassVar[str] = "controller period period_s"

    def __init__(self, kind: PlantKind, spec: Any, cls: Any, fixed: dict[str, Any], base_dir: Any = None,
                 period_s: Any = 0.01, scenario: Any = None, actuator: Any = None, sensor: Any = None,
                 cost: Any = None, requirements: Any = None, init: Any = None) -> None:
        p = period_s
        if isinstance(p, bool) or not isinstance(p, (int, float)) or not (math.isfinite(p) and p > 0):
            raise ValueError(f"objective.period_s: the controller period must be a number > 0 s, got {p!r}")
        self.spec, self.controller, self.fixed, self.period = dict(spec), cls.name, fixed, float(p)
        self.scenario, self.actuator, self.sensor = dict(scenario or {}), dict(actuator or {}), dict(sensor or {})
        self.cost, self.requirements = dict(cost or {}), dict(requirements or {})
        self.plant = kind.build(self.spec, self.period, pathlib.Path(base_dir) if base_dir else None,
                                "objective.plant")
        self.ctrl = cls
        if cls.needs_inner and self.plant.inner_output < 0:
            raise ValueError("objective.plant.inner_output: pid_cascade needs the inner loop's output index")
        self.decl = cls.declaration_for(self.plant)
        self.decl.validate(fixed)
        self._sc = scenario_from_spec(self.scenario, self.period)
        self._real = realism_from_spec(self.actuator, self.sensor)
        # the controller's output limits default to the actuator's: its anti-windup must see the saturation
        # (with infinite limits back-calculation and clamping never act), and the export carries them
        names = {q.name for q in self.decl}
        for k in ("u_min", "u_max"):
            lim = getattr(self._real, k)
            if k in names and k not in fixed and math.isfinite(lim):
                fixed[k] = lim
        self._cost = cost_from_spec(self.cost)
        self.linear = self.plant.linear
        step = self._sc.first_step()
        self._req = requirements_from_spec(self.requirements, step is not None, self.linear,
                                           (step[1] - step[0]) * self.period if step else math.inf)
        self.init = init
        self._init = init_from_spec(init, self._req.get("max_ms"))
        self._start: Start | None = None
        if self._init is not None:
            if cls.from_ideal(1.0, 1.0, 0.0) is None:
                raise ValueError(f"objective.init: a rule gives one PID (pid2dof, pid2dof_par), not a {cls.name}")
            if self._init["max_ms"] is not None and not self.linear:
                raise ValueError("objective.init.max_ms: Ms needs an LTI plant (tf, zpk, ss); leave max_ms out")
        n_meas = self.plant.n_states if cls.name == "lqr_sf" else self.plant.n_outputs
        std = np.array(self._real.noise_std, dtype=float)
        if std.size not in (1, n_meas):
            raise ValueError(f"objective.sensor.noise_std: one value or {n_meas} (one per measured signal), "
                             f"got {std.size}")
        rng = np.random.default_rng(self._real.seed)
        noise = rng.standard_normal((self._sc.t.size, n_meas)) * std if np.any(std > 0) \
            else np.zeros((self._sc.t.size, n_meas))
        self._sig = np.ascontiguousarray(np.column_stack([self._sc.r, self._sc.load, noise]))
        if self.linear:
            self._omega = frequency_grid(self.period)
            self._pr = {"outputs": plant_response(self.plant, self._omega, False)}
            if cls.name == "lqr_sf":
                self._pr["states"] = plant_response(self.plant, self._omega, True)

    # --- construction from YAML --------------------------------------------------------------------
    @classmethod
    def settings_from_config(cls, section: Mapping[str, Any], base_dir: pathlib.Path | None) -> dict[str, Any]:
        """The loop's settings of the YAML ``objective:`` mapping; unknown keys and non-mappings are
        ``ValueError`` naming the key."""
        allowed = cls.KEYS | {"kind", "plant", "controller", "fixed"}
        unknown = sorted(set(section) - allowed)
        if unknown:
            raise ValueError(f"objective.{unknown[0]}: unknown key for a plant mapping; allowed: {sorted(allowed)}")
        for k in ("fixed", "scenario", "actuator", "sensor", "cost", "requirements"):
            if section.get(k) is not None and not isinstance(section[k], Mapping):
                raise ValueError(f"objective.{k}: expected a mapping, got {section[k]!r}")
        return {"period_s": section.get("period_s", 0.01), "init": section.get("init"),
                **{k: dict(section.get(k) or {}) for k in ("scenario", "actuator", "sensor", "cost", "requirements")}}

    @staticmethod
    def error_key(msg: str) -> str:
        """``msg`` with the config key it concerns in front (``objective.fixed`` for a controller value)."""
        if msg.startswith("objective"):
            return msg
        return f"{'objective.fixed' if msg.startswith('controller') else 'objective'}: {msg}"

    def settings(self) -> dict[str, Any]:
        """The settings this loop was built from (the objective pickles them)."""
        return {"period_s": self.period, "scenario": self.scenario, "actuator": self.actuator,
                "sensor": self.sensor, "cost": self.cost, "requirements": self.requirements, "init": self.init}

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
        return {"objective": {"kind": "closed_loop", "controller": self.controller, "plant": dict(self.spec),
                              "period_s": self.period}, "data": self.scenario}

    def scoring(self) -> dict[str, Any]:
        """The plant, scenario, actuator, sensor, cost and requirements: they only serve scoring."""
        return {"plant": self.spec, "scenario": self.scenario, "actuator": self.actuator, "sensor": self.sensor,
                "cost": self.cost, "requirements": self.requirements}

    def notes(self) -> list[str]:
        s = self.start()
        return [f"the controller runs every period_s = {self.period:g} s; its discrete coefficients are "
                "in the export's tables"] + ([f"the search started from {s.describe()}"] if s else [])

    def coeffs(self, params: Mapping[str, Any] | None) -> np.ndarray:
        """Kernel coefficients of ``params`` (with ``fixed`` and defaults); ValueError if not designable."""
        v = self.decl.validate({**self.fixed, **dict(params or {})})
        return self.ctrl.coeffs(v, self.plant)

    def build(self, values: Mapping[str, Any]) -> DeployedController:
        """The deployed controller of ``values``: every value and the kernel coefficients at the period."""
        return DeployedController(self.controller, dict(values), self.period, self.ctrl.coeffs(values, self.plant))

    def export_tables(self, values: Mapping[str, Any]) -> dict[str, Any] | None:
        """The discrete controller for ``tuner export``: gains and difference-equation coefficients."""
        return self.ctrl.tables(self.coeffs(values), self.plant) or None

    # --- evaluation --------------------------------------------------------------------------------
    def simulate(self, params: Mapping[str, Any] | None = None) -> dict[str, Any]:
        """The closed loop of ``params``: t, r, load, y (N, p), u (N, m), x (N, n), status, n_done."""
        return simulate_loop(self.plant, self.ctrl.kind, self.coeffs(params), self._sig, self._real)

    def evaluate_batch(self, params_list: list[Mapping[str, Any]], n_threads: int) -> None:
        """No population kernel: the engine evaluates the generation serially."""
        return None

    def loop_margins(self, params: Mapping[str, Any] | None) -> dict[str, float]:
        """``ms``, ``gm_db``, ``pm_deg`` and ``cl_pole_max`` (largest |closed-loop pole| of the linear
        loop) for linear plants (:mod:`.analysis`: the grid's extrema and crossings refined on the exact loop
        response, so Ms is the true peak to far below 1e-6); an unstable linear loop has ``ms = inf`` and margins
        ``-inf``, since its frequency response says nothing of its robustness."""
        cp = self.coeffs(params)
        pole = float(np.max(np.abs(closed_loop_poles(self.ctrl.kind, cp, self.plant))))
        if not pole < 1.0:
            return {"ms": math.inf, "gm_db": -math.inf, "pm_deg": -math.inf, "cl_pole_max": pole,
                    "wc_rad_s": math.nan, "w180_rad_s": math.nan}
        L = loop_response(self.ctrl, cp, self.plant, self._omega, self._pr)
        exact = exact_loop(self.ctrl, cp, self.plant, "states" in self._pr)
        return {**margins(L, self._omega, exact, math.pi / self.period), "cl_pole_max": pole}

    def evaluation(self, sim: Mapping[str, Any], params: Mapping[str, Any] | None = None) -> Evaluation:
        """Score one simulation of ``params``: cost, step metrics, margins (linear plants), requirements."""
        h, n = self.period, sim["n_done"]
        y, u, x = sim["y"], sim["u"], sim["x"]
        m: dict[str, float] = {"status_code": float(sim["status"])}
        if sim["status"] != 0:
            why = "returned a wrong shape" if sim["status"] == 3 else "diverged"
            return Evaluation.failed(f"closed loop {why} at t={n * h:.3g} s", m)
        out = self.plant.output
        e = self._sc.r - y[:, out]
        f, terms = loop_cost(self._cost, self._sc.t, e, u[:, 0], y, x, h)
        m.update(terms)
        m.update(step_metrics(self._sc, y[:, out], h))
        m["peak_u"] = float(np.max(np.abs(u))) if u.size else 0.0
        if self.linear:
            mg = self.loop_margins(params)
            m.update({k: mg[k] for k in ("ms", "gm_db", "pm_deg", "cl_pole_max")})
        bad = check_requirements(self._req, m)
        if bad:
            return Evaluation.failed(f"requirement violated: {bad}", m)
        if not math.isfinite(f):
            return Evaluation.failed(f"non-finite cost {f}", m)
        return Evaluation(f, m)

    def requirement_rows(self, ev: Evaluation) -> list[dict[str, Any]]:
        """``[{requirement, what, limit, value, met}]`` of the evaluation ``ev``."""
        rows = []
        for key, lim in self._req.items():
            metric, sense, what = REQUIREMENTS[key]
            v = ev.metrics.get(metric, math.nan)
            met = bool(v <= lim) if sense == "max" else bool(v >= lim)
            rows.append({"requirement": key, "what": what, "limit": lim, "value": v, "met": met})
        return rows

    # --- report ------------------------------------------------------------------------------------
    def traces(self, params: Mapping[str, Any]) -> dict[str, dict[str, Any]]:
        s = self.simulate(params)
        return {"output y": {"t": self._sc.t, "y": s["y"][:, self.plant.output], "ref": self._sc.r},
                "control u": {"t": self._sc.t, "y": s["u"][:, 0], "ref": None}}

    def finalize(self, run_dir: pathlib.Path, init: dict[str, Any], best: dict[str, Any]) -> dict[str, Any]:
        """Response figure (defaults and tuned; a load-disturbance panel when the scenario has one), for
        linear plants a Bode plot with the margins, ``requirements.md``; returns the scores of both."""
        from objectives.control.plants.report import write_report

        return write_report(self, run_dir, init, best)
