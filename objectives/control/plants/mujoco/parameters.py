"""The named physical parameters of a MuJoCo model: what an uncertainty block (or ``parameters:``) may change.

A parameter is ``<element>.<name>.<field>`` of a *named* element of the compiled model:

==============================  =============================================================  ==========
name                            what (MuJoCo field)                                            unit
==============================  =============================================================  ==========
``body.<b>.mass``               the body's mass (``body_mass``)                                kg
``body.<b>.ixx|iyy|izz``        its principal moments of inertia (``body_inertia``)            kg m^2
``joint.<j>.damping``           viscous damping of each of its dofs (``dof_damping``)          N m s/rad
``joint.<j>.frictionloss``      dry friction of each of its dofs (``dof_frictionloss``)        N m
``joint.<j>.armature``          rotor inertia added to each of its dofs (``dof_armature``)     kg m^2
``joint.<j>.stiffness``         its spring stiffness (``jnt_stiffness``)                       N m/rad
``actuator.<a>.gain``           its gain ``gainprm[0]``; a new value scales ``gainprm`` and    force/ctrl
                                ``biasprm`` together, so a servo's whole force law is scaled
``geom.<g>.friction``           its sliding friction coefficient (``geom_friction[0]``)         1
==============================  =============================================================  ==========

(units for hinge joints; a slide joint's are N, m, kg.) A body's mass and inertia are independent
parameters (MuJoCo keeps both); perturb both to model a change of density. After a change the model's
derived constants are recomputed (``mj_setConst``), as MuJoCo requires after editing masses.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np

__all__ = ["named_parameters", "apply_parameters", "FIELDS"]

#: element -> its fields
FIELDS = {"body": ("mass", "ixx", "iyy", "izz"), "joint": ("damping", "frictionloss", "armature", "stiffness"),
          "actuator": ("gain",), "geom": ("friction",)}
_INERTIA = {"ixx": 0, "iyy": 1, "izz": 2}


def _objects(m: Any, element: str) -> list[tuple[int, str]]:
    """``(id, name)`` of the named objects of ``element`` (the world body left out)."""
    import mujoco

    obj = {"body": mujoco.mjtObj.mjOBJ_BODY, "joint": mujoco.mjtObj.mjOBJ_JOINT,
           "actuator": mujoco.mjtObj.mjOBJ_ACTUATOR, "geom": mujoco.mjtObj.mjOBJ_GEOM}[element]
    count = {"body": m.nbody, "joint": m.njnt, "actuator": m.nu, "geom": m.ngeom}[element]
    out = []
    for i in range(1 if element == "body" else 0, count):
        name = mujoco.mj_id2name(m, obj, i)
        if name:
            out.append((i, name))
    return out


def _dofs(m: Any, j: int) -> range:
    import mujoco

    n = {mujoco.mjtJoint.mjJNT_FREE: 6, mujoco.mjtJoint.mjJNT_BALL: 3}.get(int(m.jnt_type[j]), 1)
    return range(int(m.jnt_dofadr[j]), int(m.jnt_dofadr[j]) + n)


def named_parameters(m: Any) -> dict[str, float]:
    """Every named parameter of the compiled model ``m`` with its value (module docstring)."""
    out: dict[str, float] = {}
    for i, name in _objects(m, "body"):
        out[f"body.{name}.mass"] = float(m.body_mass[i])
        for f, c in _INERTIA.items():
            out[f"body.{name}.{f}"] = float(m.body_inertia[i, c])
    for j, name in _objects(m, "joint"):
        d = _dofs(m, j)[0]
        out[f"joint.{name}.damping"] = float(m.dof_damping[d])
        out[f"joint.{name}.frictionloss"] = float(m.dof_frictionloss[d])
        out[f"joint.{name}.armature"] = float(m.dof_armature[d])
        out[f"joint.{name}.stiffness"] = float(m.jnt_stiffness[j])
    for a, name in _objects(m, "actuator"):
        if m.actuator_gainprm[a, 0] != 0.0:
            out[f"actuator.{name}.gain"] = float(m.actuator_gainprm[a, 0])
    for g, name in _objects(m, "geom"):
        out[f"geom.{name}.friction"] = float(m.geom_friction[g, 0])
    return out


def _check(key: str, name: str, value: Any, known: Mapping[str, float]) -> float:
    if name not in known:
        element = name.split(".")[0]
        close = sorted(k for k in known if k.startswith(element + "."))[:12] if element in FIELDS else []
        hint = f"; e.g. {close}" if close else f"; elements: {sorted(FIELDS)} (<element>.<name>.<field>)"
        raise ValueError(f"{key}.{name}: not a named parameter of this model{hint}")
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise ValueError(f"{key}.{name}: must be a finite number, got {value!r}")
    field = name.rsplit(".", 1)[1]
    if value < 0 or (field in ("mass", "ixx", "iyy", "izz", "gain") and value <= 0):
        rel = ">" if field in ("mass", "ixx", "iyy", "izz", "gain") else ">="
        raise ValueError(f"{key}.{name}: must be {rel} 0, got {value!r}")
    return float(value)


def apply_parameters(m: Any, values: Mapping[str, Any], key: str = "objective.plant.parameters") -> None:
    """Set ``values`` (``{name: value}``) in the compiled model ``m`` in place and recompute its derived
    constants; ``ValueError`` naming the key for an unknown name or a value outside the physical range."""
    import mujoco

    if not values:
        return
    known = named_parameters(m)
    ids = {el: {n: i for i, n in _objects(m, el)} for el in FIELDS}
    for name, value in values.items():
        v = _check(key, str(name), value, known)
        element, obj, field = _split(name)
        i = ids[element][obj]
        if element == "body":
            if field == "mass":
                m.body_mass[i] = v
            else:
                m.body_inertia[i, _INERTIA[field]] = v
        elif element == "joint":
            if field == "stiffness":
                m.jnt_stiffness[i] = v
            else:
                getattr(m, f"dof_{field}")[list(_dofs(m, i))] = v
        elif element == "actuator":
            s = v / float(m.actuator_gainprm[i, 0])
            m.actuator_gainprm[i] = np.asarray(m.actuator_gainprm[i]) * s
            m.actuator_biasprm[i] = np.asarray(m.actuator_biasprm[i]) * s
        else:
            m.geom_friction[i, 0] = v
    mujoco.mj_setConst(m, mujoco.MjData(m))


def _split(name: str) -> tuple[str, str, str]:
    element, rest = name.split(".", 1)
    obj, field = rest.rsplit(".", 1)
    return element, obj, field
