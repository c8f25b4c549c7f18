"""The closed-loop objective's ``deployment`` and ``build`` hooks: the complete tuned controller.

The deployed controller is defined by every value of its declaration (searched, fixed, defaults) and
by the sampling period ``Ts_s`` it runs at (``sample_rate_hz``). The plant model, the reference
profile, the cost weights, the requirements and the sensor noise only serve scoring the run in
simulation: they go under ``scoring``. A design that depends on the plant (LQR/LQG linearise the
model) is exported with its resulting matrices by ``export_tables``.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from tuner.deployment import Deployment, build_deployment

__all__ = ["controller_deployment", "controller_build"]

#: the objective's fields that only serve scoring the closed loop in simulation
_SCORING = ("plant_params", "sensors", "profile", "cost", "noise_seed", "duration_s", "n_sub", "fall_limit_deg",
            "max_mae_nu", "max_mae_xi_deg_s", "max_rise_time_s", "max_settle_theta3_s")


def controller_deployment(obj: Any, params: Mapping[str, Any]) -> Deployment:
    """The deployment of ``params`` (:func:`tuner.deployment.build_deployment`)."""
    cls = obj._cls
    return build_deployment("closed_loop", obj.controller, cls.resolve({**obj.fixed, **params}), searched=params,
                            fixed=obj.fixed, decl=cls.decl,
                            scoring={k: getattr(obj, k) for k in _SCORING if getattr(obj, k) is not None},
                            sample_rate_hz=1.0 / float(obj._sensors.Ts_s),
                            notes=[f"the controller runs every Ts_s = {obj._sensors.Ts_s:g} s"])


def controller_build(obj: Any, params: Mapping[str, Any]) -> Any:
    """The deployed controller: an instance for the objective's plant and sensors whose ``values`` hold
    every value and whose ``param_array()`` is the kernel's parameter array of exactly those."""
    ctrl = obj._cls(obj._plant, obj._sensors)
    ctrl.values = obj._cls.resolve({**obj.fixed, **params})
    return ctrl
