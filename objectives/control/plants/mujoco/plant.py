"""The registered kind ``mujoco``: a MuJoCo model (MJCF, or URDF through MuJoCo's compiler) as a plant.

No module of the unit imports MuJoCo at import time: the registry, ``tuner describe plant`` and every job
without a MuJoCo plant work without the optional ``mujoco`` package (``pip install -e '.[mujoco]'``); the
builder imports it and says how to install it when it is missing.
"""

from __future__ import annotations

import pathlib
from collections.abc import Mapping
from typing import Any

from objectives.control.plants.base import PlantKind
from objectives.control.plants.mujoco.model import MJ_KEYS, mujoco_from_spec

__all__ = ["MUJOCO", "build"]


def build(spec: Mapping[str, Any], period_s: float, base_dir: pathlib.Path | None, key: str = "objective.plant") -> Any:
    """The :class:`~objectives.control.plants.mujoco.model.MujocoPlant` of ``spec`` (``ValueError`` naming the
    key for bad input, or when the mujoco package is missing)."""
    try:
        import mujoco  # noqa: F401 - only to say what is missing before anything else
    except ImportError:
        raise ValueError(f"{key}.mujoco: MuJoCo plants need the mujoco package (pip install -e '.[mujoco]')") from None
    return mujoco_from_spec(spec, period_s, base_dir, key)


#: the registered kind (objectives.control.plants.PLANTS): its own loop family, several inputs and outputs
MUJOCO = PlantKind("mujoco", MJ_KEYS, build, "mujoco",
                   "path.xml or .urdf (MuJoCo, extra mujoco); actuators, outputs, state_joints, keyframe, qpos/qvel/"
                   "ctrl, timestep_s, ctrlrange, motors, loops, parameters; controllers joint_pid, lqr_fd")
