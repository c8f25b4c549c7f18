"""``tuner describe NAME`` for the closed-loop objective: a controller, the plants, the generic loop's
settings (requirements, scenario, actuator, sensor, cost, aggregate, uncertainty:
:mod:`objectives.control.settings_doc`), the eq. 2.39 cost or a pendulum reference profile, all read from
their registries and declarations."""

from __future__ import annotations

from typing import Any

__all__ = ["explain"]

#: options every plant of the generic loop takes besides its kind's own keys
_LOOP_OPTIONS = (("dt", "the model is discrete with this period (s); else continuous, discretised at period_s"),
                 ("method", "zoh | tustin: discretisation of a continuous model"),
                 ("delay_s", "input delay (s), a whole number of controller periods"),
                 ("output", "index of the controlled output"),
                 ("inner_output", "index of the inner loop's output (pid_cascade)"))


def _plants() -> dict[str, Any]:
    from objectives.control.plants import PLANTS, get_plant_kind

    keys = [(k, get_plant_kind(k).doc) for k in PLANTS]
    return {"section": "plants", "name": "plant", "summary": "plant of a closed-loop job (objective.plant)",
            "usage": "objective: {kind: closed_loop, plant: {tf: {num: [1], den: [1, 1]}}, "
                     "controller: pid2dof, period_s: 0.01, scenario: {duration_s: 5}}",
            "params": [{"name": k, "doc": d} for k, d in (*keys, *_LOOP_OPTIONS)]}


def explain(name: str) -> dict[str, Any] | None:
    """The description of ``name`` (``tuner describe``), or None when it is none of the closed loop's."""
    from objectives.control.controllers import CONTROLLERS, get_controller
    from objectives.control.settings_doc import SETTINGS, describe_setting

    if name == "plant":
        return _plants()
    if name in SETTINGS:
        return describe_setting(name)
    if name in CONTROLLERS:
        cls = get_controller(name)
        d = {"section": "controllers", **cls.describe()}
        if cls.family != "wmp":
            plant = "{mujoco: robot.xml, keyframe: ...}" if cls.family == "mujoco" else "{tf: ...}"
            d["usage"] = f"objective: {{kind: closed_loop, plant: {plant}, controller: {name}}}"
        return d
    if name == "mae_weighted_cost":
        from objectives.control.plants.wmp.metrics import DEFAULT_COST_WEIGHTS, mae_weighted_cost

        doc = (mae_weighted_cost.__doc__ or "").strip().splitlines()[0]
        weights = [{"name": k, "default": v, "unit": "1", "doc": "exponent (objective.cost)", "eq": "eq. 2.39"}
                   for k, v in DEFAULT_COST_WEIGHTS.items()]
        return {"section": "metrics", "name": name, "summary": doc, "unit": "SI (see docs/control-cost.md)",
                "eq": "thesis eq. 2.39", "usage": "objective: {kind: closed_loop, cost: {alpha1: 1.4, ...}}",
                "params": weights}
    from objectives.control.plants.wmp.profiles import PROFILES

    if name in PROFILES:
        return {"section": "data", "name": name, "summary": "closed-loop reference profile (speed, yaw rate)",
                "usage": f"objective: {{kind: closed_loop, profile: {name}}}", "params": []}
    return None
