"""The start orientation every filter shares: a quaternion from one accelerometer/magnetometer sample
(BROAD's ``quatFromAccMag``), from a rotation matrix, or as a filter's ``init`` option asks
(:func:`initial_quaternion`). Re-exported by :mod:`objectives.attitude.filters.base`.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from objectives.attitude.data.recording import Recording

__all__ = ["initial_quaternion", "quat_from_acc_mag", "quat_from_rotmat"]


def quat_from_rotmat(R: np.ndarray) -> np.ndarray:
    """Unit quaternion (w, x, y, z), w >= 0, of a rotation matrix (Shepperd's method)."""
    R = np.asarray(R, float)
    tr = R[0, 0] + R[1, 1] + R[2, 2]
    if tr > 0:
        s = 2.0 * math.sqrt(1.0 + tr)
        q = np.array([0.25 * s, (R[2, 1] - R[1, 2]) / s, (R[0, 2] - R[2, 0]) / s, (R[1, 0] - R[0, 1]) / s])
    elif R[0, 0] > R[1, 1] and R[0, 0] > R[2, 2]:
        s = 2.0 * math.sqrt(1.0 + R[0, 0] - R[1, 1] - R[2, 2])
        q = np.array([(R[2, 1] - R[1, 2]) / s, 0.25 * s, (R[0, 1] + R[1, 0]) / s, (R[0, 2] + R[2, 0]) / s])
    elif R[1, 1] > R[2, 2]:
        s = 2.0 * math.sqrt(1.0 + R[1, 1] - R[0, 0] - R[2, 2])
        q = np.array([(R[0, 2] - R[2, 0]) / s, (R[0, 1] + R[1, 0]) / s, 0.25 * s, (R[1, 2] + R[2, 1]) / s])
    else:
        s = 2.0 * math.sqrt(1.0 + R[2, 2] - R[0, 0] - R[1, 1])
        q = np.array([(R[1, 0] - R[0, 1]) / s, (R[0, 2] + R[2, 0]) / s, (R[1, 2] + R[2, 1]) / s, 0.25 * s])
    q /= np.linalg.norm(q)
    return q if q[0] >= 0 else -q


def quat_from_acc_mag(acc: np.ndarray, mag: np.ndarray | None, frame: str = "ENU") -> np.ndarray:
    """Sensor-to-earth quaternion from one accelerometer (and magnetometer) sample.

    ``acc`` points up in the sensor frame (specific force at rest). With ``mag`` the heading follows
    the horizontal magnetic field (magnetic north = earth north); without it the heading is chosen
    so that the sensor's x axis projects on north (zero yaw). This is BROAD's ``quatFromAccMag``.
    """
    up = np.asarray(acc, float) / np.linalg.norm(acc)
    if mag is not None and np.all(np.isfinite(mag)) and np.linalg.norm(np.cross(mag, up)) > 1e-12:
        east = np.cross(mag, up)
    else:
        east = np.cross(np.array([1.0, 0.0, 0.0]), up)
        if np.linalg.norm(east) < 1e-9:
            east = np.cross(np.array([0.0, 1.0, 0.0]), up)
        east = -east
        # x_s x up points west when x_s is north-ish; negate for east
    east /= np.linalg.norm(east)
    north = np.cross(up, east)
    if frame.upper() == "ENU":
        R = np.vstack([east, north, up])  # rows: earth axes in sensor coords -> v_e = R v_s
    elif frame.upper() == "NED":
        R = np.vstack([north, east, -up])
    elif frame.upper() == "NWU":
        R = np.vstack([north, -east, up])
    else:
        raise ValueError(f"frame must be ENU, NED or NWU, got {frame!r}")
    return quat_from_rotmat(R)


def initial_quaternion(rec: Recording, frame: str, q0: Any = None, use_mag: bool = True) -> np.ndarray:
    """The common initialisation of all filters.

    ``q0`` may be ``None``/``"accmag"`` (first acc/mag sample), ``"truth"`` (first finite truth sample,
    converted to ``frame``), ``"broad"`` (BROAD's own start, :mod:`objectives.attitude.init_broad`; needs a
    magnetometer) or an explicit (4,) quaternion in ``frame``.
    """
    from objectives.attitude.quaternion import to_frame

    if isinstance(q0, str) and q0 == "broad":
        from objectives.attitude.init_broad import broad_initial_quaternion

        return broad_initial_quaternion(rec, frame)

    if q0 is None or (isinstance(q0, str) and q0 == "accmag"):
        mag = rec.mag[0] if (use_mag and rec.mag is not None) else None
        return quat_from_acc_mag(rec.acc[0], mag, frame)
    if isinstance(q0, str) and q0 == "truth":
        if rec.quat is None:
            raise ValueError(f"{rec.name}: q0='truth' but the recording has no truth")
        ok = np.isfinite(rec.quat).all(axis=1)
        if not ok.any():
            raise ValueError(f"{rec.name}: q0='truth' but every truth sample is NaN")
        return to_frame(rec.quat[int(np.argmax(ok))], rec.frame, frame)
    q = np.asarray(q0, float).reshape(-1)
    if q.shape != (4,) or not np.all(np.isfinite(q)) or np.linalg.norm(q) == 0:
        raise ValueError(f"q0 must be 'accmag', 'truth', 'broad' or a finite (4,) quaternion, got {q0!r}")
    return q / np.linalg.norm(q)
