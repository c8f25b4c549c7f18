"""The closed-loop objective for any plant: ``objective: {kind: closed_loop, plant: {...}}``.

YAML (``objective:``; keys of :mod:`.lti`, :mod:`.nonlinear` and :mod:`.scenario`)::

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

Calling it with controller parameters returns :class:`tuner.objective.Evaluation`: the cost and the
metrics (every cost term, the step metrics, ``peak_u``, and for LTI plants ``ms``, ``gm_db``,
``pm_deg`` and ``cl_pole_max``, the largest |pole| of the linear closed loop: above 1 the loop is
unstable and Ms is inf); a diverging loop, a design without solution or a violated requirement is a failed
evaluation with the reason. The noise is drawn once from ``sensor.seed``: every candidate sees the same.
"""

from __future__ import annotations

import math
import pathlib
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from objectives.control.plants import build_plant
from objectives.control.plants.controllers import LOOP_CONTROLLERS, get_loop_controller
from objectives.control.plants.scenario import check_requirements as _check
from objectives.control.plants.scenario import (
    cost_from_spec,
    loop_cost,
    realism_from_spec,
    requirements_from_spec,
    scenario_from_spec,
    step_metrics,
)
from objectives.control.plants.simulate import simulate_loop
from tuner.deployment import Deployment, build_deployment
from tuner.objective import Evaluation
from tuner.space import Real, Space

__all__ = ["LoopObjective", "LOOP_KEYS", "DeployedController"]

LOOP_KEYS = {"kind", "plant", "controller", "fixed", "period_s", "scenario", "actuator", "sensor", "cost",
             "requirements"}


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


@dataclass
class LoopObjective:
    """Picklable generic closed-loop objective (module docstring); derived state is rebuilt on unpickling."""

    plant: dict[str, Any]
    controller: str = "pid2dof"
    fixed: dict[str, Any] = field(default_factory=dict)
    period_s: float = 0.01
    scenario: dict[str, Any] = field(default_factory=dict)
    actuator: dict[str, Any] = field(default_factory=dict)
    sensor: dict[str, Any] = field(default_factory=dict)
    cost: dict[str, Any] = field(default_factory=dict)
    requirements: dict[str, Any] = field(default_factory=dict)
    base_dir: str | None = None

    def __post_init__(self) -> None:
        p = self.period_s
        if isinstance(p, bool) or not isinstance(p, (int, float)) or not (math.isfinite(p) and p > 0):
            raise ValueError(f"objective.period_s: the controller period must be a number > 0 s, got {p!r}")
        self._plant = build_plant(self.plant, float(p), pathlib.Path(self.base_dir) if self.base_dir else None)
        self._ctrl = get_loop_controller(self.controller)
        if self._ctrl.needs_inner and self._plant.inner_output < 0:
            raise ValueError("objective.plant.inner_output: pid_cascade needs the inner loop's output index")
        self._decl = self._ctrl.declaration_for(self._plant)
        self._decl.validate(self.fixed)
        self._sc = scenario_from_spec(self.scenario, float(p))
        self._real = realism_from_spec(self.actuator, self.sensor)
        # the controller's output limits default to the actuator's: its anti-windup must see the saturation
        # (with infinite limits back-calculation and clamping never act), and the export carries them
        names = {q.name for q in self._decl}
        for k in ("u_min", "u_max"):
            lim = getattr(self._real, k)
            if k in names and k not in self.fixed and math.isfinite(lim):
                self.fixed[k] = lim
        self._cost = cost_from_spec(self.cost)
        self.lti = hasattr(self._plant, "Ad")
        step = self._sc.first_step()
        self._req = requirements_from_spec(self.requirements, step is not None, self.lti,
                                           (step[1] - step[0]) * float(p) if step else math.inf)
        n_meas = self._plant.n_states if self._ctrl.name == "lqr_sf" else self._plant.n_outputs
        std = np.array(self._real.noise_std, dtype=float)
        if std.size not in (1, n_meas):
            raise ValueError(f"objective.sensor.noise_std: one value or {n_meas} (one per measured signal), "
                             f"got {std.size}")
        rng = np.random.default_rng(self._real.seed)
        noise = rng.standard_normal((self._sc.t.size, n_meas)) * std if np.any(std > 0) \
            else np.zeros((self._sc.t.size, n_meas))
        self._sig = np.ascontiguousarray(np.column_stack([self._sc.r, self._sc.load, noise]))
        if self.lti:
            from objectives.control.plants.analysis import frequency_grid, plant_response

            self._omega = frequency_grid(float(p))
            self._pr = {"outputs": plant_response(self._plant, self._omega, False)}
            if self._ctrl.name == "lqr_sf":
                self._pr["states"] = plant_response(self._plant, self._omega, True)

    # --- construction ---------------------------------------------------------------------------
    @classmethod
    def from_config(cls, section: Mapping[str, Any], base_dir: pathlib.Path | None = None) -> LoopObjective:
        section = dict(section)
        unknown = sorted(set(section) - LOOP_KEYS)
        if unknown:
            raise ValueError(f"objective.{unknown[0]}: unknown key for a plant mapping; allowed: {sorted(LOOP_KEYS)}")
        for k in ("fixed", "scenario", "actuator", "sensor", "cost", "requirements"):
            if section.get(k) is not None and not isinstance(section[k], Mapping):
                raise ValueError(f"objective.{k}: expected a mapping, got {section[k]!r}")
        ctrl = section.get("controller", "pid2dof")
        if not isinstance(ctrl, str):
            raise ValueError(f"objective.controller: expected a name, got {ctrl!r}")
        try:
            return cls(plant=dict(section["plant"]), controller=ctrl, fixed=dict(section.get("fixed") or {}),
                       period_s=section.get("period_s", 0.01), scenario=dict(section.get("scenario") or {}),
                       actuator=dict(section.get("actuator") or {}), sensor=dict(section.get("sensor") or {}),
                       cost=dict(section.get("cost") or {}), requirements=dict(section.get("requirements") or {}),
                       base_dir=str(base_dir) if base_dir is not None else None)
        except ValueError as exc:
            msg = str(exc)
            if not msg.startswith("objective"):
                where = "objective.fixed" if msg.startswith("controller") else "objective"
                msg = f"{where}: {msg}"
            raise ValueError(msg) from None

    # --- engine hooks ---------------------------------------------------------------------------
    def default_space(self) -> Space:
        return Space(Real(p.name, fixed=self.fixed[p.name], unit=p.unit, doc=p.doc) if p.name in self.fixed
                     else p.real() for p in self._decl)

    def default_params(self) -> dict[str, Any]:
        return self._decl.validate(self.fixed)

    def parameter_names(self) -> list[str]:
        return self._decl.names()

    def check_params(self, params: Mapping[str, Any]) -> None:
        self._decl.validate({**self.fixed, **params})

    def sample_rate(self) -> tuple[float | None, str]:
        return 1.0 / float(self.period_s), "controller period period_s"

    def describe(self) -> dict[str, Any]:
        plant = {k: v for k, v in self.plant.items()}
        return {"objective": {"kind": "closed_loop", "controller": self.controller, "plant": plant,
                              "period_s": self.period_s}, "data": self.scenario}

    def coeffs(self, params: Mapping[str, Any] | None) -> np.ndarray:
        """Kernel coefficients of ``params`` (with ``fixed`` and defaults); ValueError if not designable."""
        v = self._decl.validate({**self.fixed, **dict(params or {})})
        return self._ctrl.coeffs(v, self._plant)

    def simulate(self, params: Mapping[str, Any] | None = None) -> dict[str, Any]:
        """The closed loop of ``params``: t, r, load, y (N, p), u (N, m), x (N, n), status, n_done."""
        cp = self.coeffs(params)
        return simulate_loop(self._plant, self._ctrl.kind, cp, self._sig, self._real)

    def loop_margins(self, params: Mapping[str, Any] | None) -> dict[str, float]:
        """``ms``, ``gm_db``, ``pm_deg`` and ``cl_pole_max`` (largest |closed-loop pole| of the linear
        loop) for LTI plants (:mod:`.analysis`); an unstable linear loop has ``ms = inf`` and margins
        ``-inf``, since its frequency response says nothing of its robustness."""
        from objectives.control.plants.analysis import closed_loop_poles, loop_response, margins

        cp = self.coeffs(params)
        pole = float(np.max(np.abs(closed_loop_poles(self._ctrl.kind, cp, self._plant))))
        if not pole < 1.0:
            return {"ms": math.inf, "gm_db": -math.inf, "pm_deg": -math.inf, "cl_pole_max": pole,
                    "wc_rad_s": math.nan, "w180_rad_s": math.nan}
        L = loop_response(self._ctrl, cp, self._plant, self._omega, self._pr)
        return {**margins(L, self._omega), "cl_pole_max": pole}

    def __call__(self, params: Mapping[str, Any]) -> Evaluation:
        try:
            sim = self.simulate(params)
        except ValueError as exc:
            return Evaluation.failed(f"controller design failed: {exc}")
        return self._evaluation(params, sim)

    def _evaluation(self, params: Mapping[str, Any], sim: Mapping[str, Any]) -> Evaluation:
        h, n = float(self.period_s), sim["n_done"]
        y, u, x = sim["y"], sim["u"], sim["x"]
        m: dict[str, float] = {"status_code": float(sim["status"])}
        if sim["status"] != 0:
            why = "returned a wrong shape" if sim["status"] == 3 else "diverged"
            return Evaluation.failed(f"closed loop {why} at t={n * h:.3g} s", m)
        out = self._plant.output
        e = self._sc.r - y[:, out]
        f, terms = loop_cost(self._cost, self._sc.t, e, u[:, 0], y, x, h)
        m.update(terms)
        m.update(step_metrics(self._sc, y[:, out], h))
        m["peak_u"] = float(np.max(np.abs(u))) if u.size else 0.0
        if self.lti:
            mg = self.loop_margins(params)
            m.update({k: mg[k] for k in ("ms", "gm_db", "pm_deg", "cl_pole_max")})
        bad = _check(self._req, m)
        if bad:
            return Evaluation.failed(f"requirement violated: {bad}", m)
        if not math.isfinite(f):
            return Evaluation.failed(f"non-finite cost {f}", m)
        return Evaluation(f, m)

    def requirement_rows(self, params: Mapping[str, Any]) -> list[dict[str, Any]]:
        """``[{requirement, limit, value, met}]`` of ``params``."""
        from objectives.control.plants.scenario import REQUIREMENTS

        ev = self(params)
        rows = []
        for key, lim in self._req.items():
            metric, sense, what = REQUIREMENTS[key]
            v = ev.metrics.get(metric, math.nan)
            met = bool(v <= lim) if sense == "max" else bool(v >= lim)
            rows.append({"requirement": key, "what": what, "limit": lim, "value": v, "met": met})
        return rows

    def deployment(self, params: Mapping[str, Any]) -> Deployment:
        """The complete tuned controller (every declared value) and its period; the plant, scenario,
        actuator, sensor, cost and requirements only serve scoring."""
        return build_deployment(
            "closed_loop", self.controller, self._decl.validate({**self.fixed, **params}), searched=params,
            fixed=self.fixed, decl=self._decl, sample_rate_hz=1.0 / float(self.period_s),
            scoring={"plant": self.plant, "scenario": self.scenario, "actuator": self.actuator,
                     "sensor": self.sensor, "cost": self.cost, "requirements": self.requirements},
            notes=[f"the controller runs every period_s = {float(self.period_s):g} s; its discrete coefficients "
                   "are in the export's tables"])

    def build(self, params: Mapping[str, Any]) -> DeployedController:
        """The deployed controller of ``params``: every value and the kernel coefficients at the period."""
        values = self._decl.validate({**self.fixed, **params})
        return DeployedController(self.controller, values, float(self.period_s), self._ctrl.coeffs(values, self._plant))

    def export_tables(self, params: Mapping[str, Any] | None = None) -> dict[str, Any] | None:
        """The discrete controller for ``tuner export``: gains and difference-equation coefficients."""
        return self._ctrl.tables(self.coeffs(params), self._plant) or None

    def traces(self, params: Mapping[str, Any]) -> dict[str, dict[str, Any]]:
        s = self.simulate(params)
        return {"output y": {"t": self._sc.t, "y": s["y"][:, self._plant.output], "ref": self._sc.r},
                "control u": {"t": self._sc.t, "y": s["u"][:, 0], "ref": None}}

    def finalize(self, run_dir: str | pathlib.Path, best: Mapping[str, Any]) -> dict[str, Any]:
        """Response figure (defaults and tuned; a load-disturbance panel when the scenario has one), for
        LTI plants a Bode plot with the margins, ``requirements.md``; returns the scores of both."""
        from objectives.control.plants.report import write_report

        return write_report(self, pathlib.Path(run_dir), self.default_params(), dict(best or {}))

    # --- engine catalog (tuner list / describe) -------------------------------------------------
    @staticmethod
    def explain(name: str) -> dict[str, Any] | None:
        if name == "plant":
            keys = [("wmp", "the thesis's wheeled mobile pendulum (plant: wmp; controllers pid, lqr, lqg, flc, ...)"),
                    ("tf", "{num, den}: transfer function, highest power first (objective.plant.tf)"),
                    ("zpk", "{z, p, k}: zeros, poles, gain"),
                    ("ss", "{A, B, C, D}: state space (MIMO for lqr_sf); x0 optional"),
                    ("dt", "the model is discrete with this period (s); else continuous, discretised at period_s"),
                    ("method", "zoh | tustin: discretisation of a continuous model"),
                    ("delay_s", "input delay (s), a whole number of controller periods"),
                    ("python", "'module:dynamics' with dynamics(x, u, t, params) -> dx; x0, params, n_inputs, "
                               "outputs, n_sub (RK4 steps per period), linearize_at"),
                    ("fmu", "path.fmu (FMI 2.0 co-simulation, extra fmu); inputs, outputs, parameters"),
                    ("output", "index of the controlled output"),
                    ("inner_output", "index of the inner loop's output (pid_cascade)")]
            return {"section": "plants", "name": "plant", "summary": "plant of a closed-loop job (objective.plant)",
                    "usage": "objective: {kind: closed_loop, plant: {tf: {num: [1], den: [1, 1]}}, "
                             "controller: pid2dof, period_s: 0.01, scenario: {duration_s: 5}}",
                    "params": [{"name": k, "doc": d} for k, d in keys]}
        if name in LOOP_CONTROLLERS:
            return {"section": "controllers", **LOOP_CONTROLLERS[name].describe(),
                    "usage": f"objective: {{kind: closed_loop, plant: {{tf: ...}}, controller: {name}}}"}
        return None

    # --- pickling -------------------------------------------------------------------------------
    def __getstate__(self) -> dict[str, Any]:
        return {k: v for k, v in self.__dict__.items() if not k.startswith("_") and k != "lti"}

    def __setstate__(self, state: dict[str, Any]) -> None:
        self.__dict__.update(state)
        self.__post_init__()
