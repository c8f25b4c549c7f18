"""The one controller registry of the closed-loop objective: ``objective.controller`` names.

``CONTROLLERS`` maps a YAML name to ``"module:Class"``; classes are imported on first use, so the
registry imports no controller module (and none of them imports it back). Every class follows one
protocol (:class:`Controller`):

- ``name``: the YAML name; ``kind``: its number in the one kind space (:mod:`objectives.control.kinds`);
- ``family``: the loop it runs in, the ``family`` of the plant kinds it accepts
  (:mod:`objectives.control.plants`): ``"siso"`` for the generic single-loop kernels (any LTI model,
  Python dynamics or FMU), ``"wmp"`` for the wheeled mobile pendulum's own loop, ``"mujoco"`` for MuJoCo
  models (several inputs and outputs at once);
- ``declaration_for(plant)``: its one :class:`~objectives.params.ParamSet` on that plant (a state feedback
  has one weight per state); ``describe()`` (``tuner describe``).

How a loop turns values into its kernel's coefficient array belongs to the family's loop
(:mod:`objectives.control.plants.loop`, :mod:`objectives.control.plants.wmp.loop`).

Adding a controller: its class in the plant unit that owns its kernel branch, its kind in
:mod:`objectives.control.kinds`, and one line here (or :func:`register_controller` at run time).
"""

from __future__ import annotations

import importlib
from typing import Any, ClassVar, Protocol

__all__ = ["CONTROLLERS", "Controller", "get_controller", "register_controller", "controllers_of",
           "unregister_controller"]

_WMP = "objectives.control.plants.wmp.controllers"
_SISO = "objectives.control.plants.controllers"
_MJ = "objectives.control.plants.mujoco.controllers"

CONTROLLERS: dict[str, str] = {
    # the generic loop: any plant from YAML (tf, zpk, ss, python, fmu)
    "pid2dof": f"{_SISO}:PID2DOF",
    "pid2dof_par": f"{_SISO}:PID2DOFParallel",
    "pid_cascade": f"{_SISO}:PIDCascade",
    "lqr_sf": f"{_SISO}:LQRStateFeedback",
    "open_loop": f"{_SISO}:OpenLoop",
    # the wheeled mobile pendulum of the thesis (plant: wmp)
    "lqr": f"{_WMP}.lqr:LQR",
    "lqg": f"{_WMP}.lqr:LQG",
    "pid": f"{_WMP}.pid:PID",
    "flc": f"{_WMP}.fuzzy:FLC",
    "protective_fuzzy": f"{_WMP}.fuzzy:ProtectiveFuzzy",
    "lut": f"{_WMP}.fuzzy:LUTFuzzy",
    # MuJoCo models (plant: {mujoco: model.xml}): several inputs and outputs
    "joint_pid": f"{_MJ}:JointPID",
    "lqr_fd": f"{_MJ}:LinearizedLQR",
}


class Controller(Protocol):
    """What the objective reads of a controller class (module docstring)."""

    name: ClassVar[str]
    kind: ClassVar[int]
    family: ClassVar[str]

    @classmethod
    def declaration_for(cls, plant: Any) -> Any: ...

    @classmethod
    def describe(cls) -> dict[str, Any]: ...


def _load(target: Any) -> Any:
    if not isinstance(target, str):
        return target
    module, cls = target.split(":")
    return getattr(importlib.import_module(module), cls)


def get_controller(name: str, family: str | None = None, key: str | None = None) -> Any:
    """The controller class registered as ``name``; with ``family``, one that runs in that loop.

    An unknown name, or one of another family, is a ``ValueError`` listing the names that fit (prefixed
    with ``key``, the config path, when given)."""
    where = f"{key}: " if key else ""
    if name not in CONTROLLERS:
        known = sorted(controllers_of(family)) if family else sorted(CONTROLLERS)
        tail = " for this plant" if family else ""
        raise ValueError(f"{where}unknown controller {name!r}{tail}; known: {known}")
    cls = _load(CONTROLLERS[name])
    if family is not None and cls.family != family:
        hint = (" (the pendulum's controllers need plant: wmp; for any plant use pid2dof or lqr_sf)"
                if cls.family == "wmp" else f" (it runs on plants of the {cls.family!r} loop)")
        raise ValueError(f"{where}unknown controller {name!r} for this plant{hint}; "
                         f"known: {sorted(controllers_of(family))}")
    return cls


def controllers_of(family: str | None) -> dict[str, Any]:
    """``{name: class}`` of every registered controller of ``family`` (all with None)."""
    out = {n: _load(t) for n, t in CONTROLLERS.items()}
    return {n: c for n, c in out.items() if family is None or c.family == family}


def register_controller(cls: Any, name: str | None = None) -> None:
    """Add a controller class (or ``"module:Class"``) under ``name`` (its ``name`` by default); a name
    already registered is a ``ValueError``."""
    name = name or _load(cls).name
    if name in CONTROLLERS:
        raise ValueError(f"controller {name!r} is already registered ({CONTROLLERS[name]})")
    CONTROLLERS[name] = cls


def unregister_controller(name: str) -> None:
    """Remove ``name`` (a test's own controller)."""
    CONTROLLERS.pop(name, None)
