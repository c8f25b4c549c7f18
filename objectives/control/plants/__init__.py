"""The plant registry of the closed-loop objective: YAML type key -> plant kind, and family -> loop.

``objective.plant`` is a mapping with exactly one registered type key (``{tf: {num, den}}``,
``{python: "module:f", x0}``, ...) or a registered bare name (``wmp``, also the default). The kind
(:class:`~objectives.control.plants.base.PlantKind`) says which keys the mapping may hold, how the plant
is built, and which loop family runs it; the family's loop (:data:`LOOPS`) builds the plant through the
kind and scores controllers on it, and its controllers are those of the same family in
:data:`objectives.control.controllers.CONTROLLERS`.

Adding a plant kind: one module implementing :class:`~objectives.control.plants.base.Plant` (one of its
two variants) with its ``PlantKind``, and one line in :data:`PLANTS` (or :func:`register_plant` at run
time). Entries are ``"module:attribute"`` strings, imported on first use, so this registry imports no
plant module.
"""

from __future__ import annotations

import importlib
from collections.abc import Mapping
from typing import Any

from objectives.control.plants.base import PlantKind

__all__ = ["PLANTS", "LOOPS", "plant_kind", "get_plant_kind", "register_plant", "unregister_plant", "build_plant",
           "loop_class", "PlantKind"]

_P = "objectives.control.plants"

#: type key -> the kind (in the order ``tuner describe plant`` and the error messages list them)
PLANTS: dict[str, Any] = {
    "wmp": f"{_P}.wmp.plant:WMP",
    "tf": f"{_P}.lti:TF",
    "zpk": f"{_P}.lti:ZPK",
    "ss": f"{_P}.lti:SS",
    "python": f"{_P}.nonlinear:PYTHON",
    "fmu": f"{_P}.fmu:FMU",
    "mujoco": f"{_P}.mujoco.plant:MUJOCO",
}

#: loop family -> the loop class the objective runs a plant of that family in
LOOPS: dict[str, Any] = {
    "siso": f"{_P}.loop:SISOLoop",
    "wmp": f"{_P}.wmp.loop:WMPLoop",
    "mujoco": f"{_P}.mujoco.loop:MujocoLoop",
}


def _load(target: Any) -> Any:
    if not isinstance(target, str):
        return target
    module, attr = target.split(":")
    return getattr(importlib.import_module(module), attr)


def get_plant_kind(key: str) -> PlantKind:
    """The registered kind of type key ``key`` (``KeyError`` if none)."""
    return _load(PLANTS[key])


def _expected() -> str:
    kinds = [get_plant_kind(k) for k in PLANTS]
    named = " or ".join(repr(k.key) for k in kinds if k.named)
    mapped = ", ".join(k.key for k in kinds if not k.named)
    return f"{named} or a mapping ({mapped})" if named else f"a mapping ({mapped})"


def plant_kind(spec: Any, key: str = "objective.plant") -> PlantKind:
    """The kind of the plant ``spec`` (a registered bare name, or a mapping with exactly one type key whose
    other keys are among the kind's); ``ValueError`` starting with ``key`` otherwise."""
    if isinstance(spec, str):
        kind = get_plant_kind(spec) if spec in PLANTS else None
        if kind is None or not kind.named:
            raise ValueError(f"{key}: {_expected()}, got {spec!r}")
        return kind
    if not isinstance(spec, Mapping):
        raise ValueError(f"{key}: {_expected()}, got {spec!r}")
    mapped = [k for k in PLANTS if not get_plant_kind(k).named]
    found = [k for k in mapped if k in spec]
    if len(found) != 1:
        raise ValueError(f"{key}: give exactly one of {mapped}, got keys {sorted(spec)}")
    kind = get_plant_kind(found[0])
    unknown = sorted(set(spec) - kind.keys)
    if unknown:
        raise ValueError(f"{key}.{unknown[0]}: unknown key; allowed: {sorted(kind.keys)}")
    return kind


def build_plant(spec: Any, period_s: float, base_dir: Any, key: str = "objective.plant") -> Any:
    """The plant of a mapping ``spec`` of the ``siso`` family (validated; ``ValueError`` starting with the
    key path otherwise)."""
    kind = plant_kind(spec, key)
    return kind.build(spec, period_s, base_dir, key)


def loop_class(family: str) -> Any:
    """The loop class of ``family`` (:data:`LOOPS`)."""
    return _load(LOOPS[family])


def register_plant(kind: PlantKind) -> None:
    """Add a plant kind under its key; a key already registered is a ``ValueError``."""
    if not isinstance(kind, PlantKind):
        raise TypeError(f"register_plant needs a PlantKind, got {type(kind).__name__}")
    if kind.key in PLANTS:
        raise ValueError(f"plant kind {kind.key!r} is already registered")
    if kind.family not in LOOPS:
        raise ValueError(f"plant kind {kind.key!r}: unknown family {kind.family!r}; known: {sorted(LOOPS)}")
    PLANTS[kind.key] = kind


def unregister_plant(key: str) -> None:
    """Remove the kind ``key`` (a test's own plant)."""
    PLANTS.pop(key, None)
