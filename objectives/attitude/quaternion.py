"""Quaternion kernels (numba) and earth-frame conversions.

Convention: ``q = (w, x, y, z)``, Hamilton product, ``q`` rotates sensor-frame vectors into the
earth frame: ``v_e = q * v_s * conj(q)`` (FAEKF paper section 2, eqs. 1-3, with its sensor-to-earth
reading).

Scalar kernels (``qmul``, ``qconj``, ``qrot``, ...) take and return small arrays and are meant to be
called from other ``@njit`` code; the ``*_batch`` helpers work on ``(N, 4)`` arrays.

Earth frames
------------
``ENU`` (x east, y north, z up) and ``NED`` (x north, y east, z down). A sensor-to-earth quaternion
in one frame converts to the other by left-multiplying the constant frame rotation
``Q_NED_FROM_ENU`` (or its conjugate): ``q_ned = Q_NED_FROM_ENU * q_enu``.
``NWU`` (x north, y west, z up, the frame of Madgwick's and Mahony's reference code) converts to ENU
by ``Q_ENU_FROM_NWU = (1/sqrt2, 0, 0, 1/sqrt2)``, the rotation BROAD's example code applies.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

__all__ = [
    "qmul", "qconj", "qnormalize", "qrot", "qmul_batch", "qconj_batch", "normalize_batch",
    "Q_ENU_FROM_NWU", "Q_NED_FROM_ENU", "frame_rotation", "to_frame",
]

_S = 1.0 / math.sqrt(2.0)
#: sensor-to-earth quaternion in NWU -> ENU (rotation of 90 deg about up).
Q_ENU_FROM_NWU = np.array([_S, 0.0, 0.0, _S])
#: ENU -> NED: x_ned = y_enu, y_ned = x_enu, z_ned = -z_enu (rotation of 180 deg about (1,1,0)/sqrt2).
Q_NED_FROM_ENU = np.array([0.0, _S, _S, 0.0])


@njit(cache=True, inline="always")
def qmul(p, q):
    """Hamilton product ``p * q`` of two (4,) quaternions (FAEKF paper eq. 2)."""
    out = np.empty(4)
    out[0] = p[0] * q[0] - p[1] * q[1] - p[2] * q[2] - p[3] * q[3]
    out[1] = p[0] * q[1] + p[1] * q[0] + p[2] * q[3] - p[3] * q[2]
    out[2] = p[0] * q[2] - p[1] * q[3] + p[2] * q[0] + p[3] * q[1]
    out[3] = p[0] * q[3] + p[1] * q[2] - p[2] * q[1] + p[3] * q[0]
    return out


@njit(cache=True, inline="always")
def qconj(q):
    out = np.empty(4)
    out[0] = q[0]
    out[1] = -q[1]
    out[2] = -q[2]
    out[3] = -q[3]
    return out


@njit(cache=True, inline="always")
def qnormalize(q):
    n = math.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3])
    out = np.empty(4)
    for i in range(4):
        out[i] = q[i] / n
    return out


@njit(cache=True, inline="always")
def qrot(q, v):
    """Rotate the (3,) vector ``v`` by the unit quaternion ``q``: ``q * v * conj(q)``."""
    w, x, y, z = q[0], q[1], q[2], q[3]
    out = np.empty(3)
    out[0] = (1 - 2 * (y * y + z * z)) * v[0] + 2 * (x * y - w * z) * v[1] + 2 * (x * z + w * y) * v[2]
    out[1] = 2 * (x * y + w * z) * v[0] + (1 - 2 * (x * x + z * z)) * v[1] + 2 * (y * z - w * x) * v[2]
    out[2] = 2 * (x * z - w * y) * v[0] + 2 * (y * z + w * x) * v[1] + (1 - 2 * (x * x + y * y)) * v[2]
    return out


@njit(cache=True)
def qmul_batch(p, q):
    """Row-wise product of (N, 4) arrays; either may be (4,) to broadcast."""
    p2 = p.reshape(-1, 4)
    q2 = q.reshape(-1, 4)
    n = max(p2.shape[0], q2.shape[0])
    out = np.empty((n, 4))
    for i in range(n):
        a = p2[i if p2.shape[0] > 1 else 0]
        b = q2[i if q2.shape[0] > 1 else 0]
        out[i] = qmul(a, b)
    return out


def qconj_batch(q: np.ndarray) -> np.ndarray:
    out = np.array(q, dtype=float, copy=True)
    out[..., 1:] *= -1.0
    return out


def normalize_batch(q: np.ndarray) -> np.ndarray:
    q = np.asarray(q, dtype=float)
    return q / np.linalg.norm(q, axis=-1, keepdims=True)


def frame_rotation(src: str, dst: str) -> np.ndarray:
    """Constant quaternion ``r`` with ``q_dst = r * q_src`` for sensor-to-earth quaternions."""
    src, dst = src.upper(), dst.upper()
    table = {
        ("ENU", "ENU"): np.array([1.0, 0, 0, 0]),
        ("NED", "NED"): np.array([1.0, 0, 0, 0]),
        ("NWU", "NWU"): np.array([1.0, 0, 0, 0]),
        ("ENU", "NED"): Q_NED_FROM_ENU,
        ("NED", "ENU"): qconj_batch(Q_NED_FROM_ENU),
        ("NWU", "ENU"): Q_ENU_FROM_NWU,
        ("ENU", "NWU"): qconj_batch(Q_ENU_FROM_NWU),
    }
    if (src, dst) not in table:
        via = qmul_batch(frame_rotation("ENU", dst), frame_rotation(src, "ENU"))[0]
        return via
    return np.asarray(table[(src, dst)], dtype=float)


def to_frame(q: np.ndarray, src: str, dst: str) -> np.ndarray:
    """Convert sensor-to-earth quaternions ``q`` (N, 4) or (4,) from earth frame ``src`` to ``dst``."""
    q = np.asarray(q, dtype=float)
    if src.upper() == dst.upper():
        return q.copy()
    out = qmul_batch(frame_rotation(src, dst), np.ascontiguousarray(q))
    return out[0] if q.ndim == 1 else out
