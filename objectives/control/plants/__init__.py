"""Plants of the generic closed loop: LTI models (:mod:`.lti`), Python dynamics (:mod:`.nonlinear`) and
FMUs (:mod:`.fmu`, optional: fmpy).

``objective: {kind: closed_loop, plant: {...}}`` with a mapping as plant selects
:class:`objectives.control.plants.objective.LoopObjective` (``plant: wmp`` stays the thesis's pendulum).
"""

from __future__ import annotations

import pathlib
from collections.abc import Mapping
from typing import Any

__all__ = ["build_plant", "PLANT_TYPES"]

PLANT_TYPES = ("tf", "zpk", "ss", "python", "fmu")


def build_plant(spec: Any, period_s: float, base_dir: pathlib.Path | None, key: str = "objective.plant") -> Any:
    """The plant object of ``spec`` (validated; ``ValueError`` starting with the key path otherwise).

    The plant type's key picks the builder (``*_from_spec(spec, period_s, base_dir, key)``); the keys of
    ``spec`` are checked here against that builder's set (``LTI_KEYS``, ``NL_KEYS``, ``FMU_KEYS``)."""
    if not isinstance(spec, Mapping):
        raise ValueError(f"{key}: expected 'wmp' or a mapping with one of {list(PLANT_TYPES)}, got {spec!r}")
    kinds = [k for k in PLANT_TYPES if k in spec]
    if len(kinds) != 1:
        raise ValueError(f"{key}: give exactly one of {list(PLANT_TYPES)}, got keys {sorted(spec)}")
    if kinds[0] == "fmu":
        from objectives.control.plants.fmu import FMU_KEYS as allowed
        from objectives.control.plants.fmu import fmu_from_spec as build
    elif kinds[0] == "python":
        from objectives.control.plants.nonlinear import NL_KEYS as allowed
        from objectives.control.plants.nonlinear import nonlinear_from_spec as build
    else:
        from objectives.control.plants.lti import LTI_KEYS as allowed
        from objectives.control.plants.lti import lti_from_spec as build
    unknown = sorted(set(spec) - allowed)
    if unknown:
        raise ValueError(f"{key}.{unknown[0]}: unknown key; allowed: {sorted(allowed)}")
    return build(spec, period_s, base_dir, key)
