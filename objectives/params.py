"""Parameter declarations of the domain's filters and controllers, and the array validators their
wrappers share.

The declaration mechanism (:class:`Param`, :class:`ParamSet`, :class:`Interval`, the ``check_*``
validators and the :class:`Declared` mixin) is the engine's, :mod:`tuner.params`; it is re-exported here
so that every filter and controller module declares through one import.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from tuner import params as _engine
from tuner.params import *  # noqa: F403 - the engine's declaration mechanism, re-exported

__all__ = [*_engine.__all__, "as_columns", "imu_arrays", "unit_quaternion"]


# --- shared array validators of the filter wrappers -------------------------------------------------
def as_columns(owner: str, key: str, a: Any, ncols: int) -> np.ndarray:
    """``a`` as a C-contiguous float64 (N, ncols) array; ValueError naming ``key`` otherwise."""
    arr = np.ascontiguousarray(a, dtype=np.float64)
    if arr.ndim != 2 or arr.shape[1] != ncols:
        raise ValueError(f"{owner}: {key} must have shape (N, {ncols}), got {arr.shape}")
    return arr


def imu_arrays(owner: str, gyr: Any, acc: Any, mag: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Contiguous float64 (N, 3) gyr and acc, and mag (N, 3) or an empty (0, 3) when ``None``."""
    gyr = as_columns(owner, "gyr", gyr, 3)
    acc = as_columns(owner, "acc", acc, 3)
    n = gyr.shape[0]
    if acc.shape[0] != n:
        raise ValueError(f"{owner}: acc has {acc.shape[0]} samples, gyr {n}")
    if mag is None:
        return gyr, acc, np.empty((0, 3))
    mag = as_columns(owner, "mag", mag, 3)
    if mag.shape[0] != n:
        raise ValueError(f"{owner}: mag has {mag.shape[0]} samples, gyr {n}")
    return gyr, acc, mag


def unit_quaternion(owner: str, key: str, q: Any) -> np.ndarray:
    """``q`` as a unit (4,) float64 array; ValueError unless finite and non-zero."""
    arr = np.asarray(q, dtype=np.float64).reshape(-1)
    if arr.shape != (4,) or not np.all(np.isfinite(arr)) or np.linalg.norm(arr) == 0:
        raise ValueError(f"{owner}: {key} must be a finite non-zero (4,) quaternion, got {q!r}")
    return arr / np.linalg.norm(arr)
