"""Quaternion algebra: Hamilton product, conjugate, rotation of vectors, exponential and logarithm.

Convention: ``q = (w, x, y, z)``, Hamilton product, ``q`` rotates sensor-frame vectors into the
earth frame: ``v_e = q * v_s * conj(q)`` (FAEKF paper section 2, eqs. 1-3, with its sensor-to-earth
reading). Scalar kernels (``qmul``, ``qconj``, ``qrot``, ``qexp``, ``qlog``) take and return small
arrays and are meant to be called from other ``@njit`` code; the ``*_batch`` helpers work on
``(N, 4)`` / ``(N, 3)`` arrays.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from objectives.jit import uncached

__all__ = [
    "qmul", "qconj", "qnormalize", "qrot", "qmul_batch", "qconj_batch", "normalize_batch", "qrot_batch",
    "qexp", "qlog", "qexp_batch", "qlog_batch", "make_continuous",
]

_SMALL_ANGLE = 1e-8  # rad; below it exp/log use their Taylor series


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
def _qrot_into(w, x, y, z, vx, vy, vz, out, i):
    """``q * v * conj(q)`` for the unit quaternion ``(w, x, y, z)``, written into ``out[i]``."""
    out[i, 0] = (1 - 2 * (y * y + z * z)) * vx + 2 * (x * y - w * z) * vy + 2 * (x * z + w * y) * vz
    out[i, 1] = 2 * (x * y + w * z) * vx + (1 - 2 * (x * x + z * z)) * vy + 2 * (y * z - w * x) * vz
    out[i, 2] = 2 * (x * z - w * y) * vx + 2 * (y * z + w * x) * vy + (1 - 2 * (x * x + y * y)) * vz


@njit(cache=True, inline="always")
def qrot(q, v):
    """Rotate the (3,) vector ``v`` by the unit quaternion ``q``: ``q * v * conj(q)``."""
    out = np.empty((1, 3))
    _qrot_into(q[0], q[1], q[2], q[3], v[0], v[1], v[2], out, 0)
    return out[0]


@njit(cache=True)
def _qmul_kernel(p, q, out):
    """Rows of ``out`` (N, 4): ``p[i] * q[i]``; a one-row ``p`` or ``q`` is used for every row (the products of
    :func:`qmul`, term for term, written in place: no array per row)."""
    for i in range(out.shape[0]):
        a = i if p.shape[0] > 1 else 0
        b = i if q.shape[0] > 1 else 0
        p0, p1, p2, p3 = p[a, 0], p[a, 1], p[a, 2], p[a, 3]
        q0, q1, q2, q3 = q[b, 0], q[b, 1], q[b, 2], q[b, 3]
        out[i, 0] = p0 * q0 - p1 * q1 - p2 * q2 - p3 * q3
        out[i, 1] = p0 * q1 + p1 * q0 + p2 * q3 - p3 * q2
        out[i, 2] = p0 * q2 - p1 * q3 + p2 * q0 + p3 * q1
        out[i, 3] = p0 * q3 + p1 * q2 - p2 * q1 + p3 * q0


#: the uncached twin other kernels call (objectives.jit)
_qmul_kernel_inner = uncached(_qmul_kernel)


def qmul_batch(p: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Row-wise Hamilton product of (N, 4) arrays; either may be (4,) (or one row) to broadcast.

    Returns (N, 4); a (1, 4) array when both are single quaternions.
    """
    p2, _ = _as_rows(p, 4, "qmul_batch: p")
    q2, _ = _as_rows(q, 4, "qmul_batch: q")
    if p2.shape[0] != q2.shape[0] and 1 not in (p2.shape[0], q2.shape[0]):
        raise ValueError(f"qmul_batch: p has {p2.shape[0]} rows, q has {q2.shape[0]}; need equal counts or one row")
    out = np.empty((max(p2.shape[0], q2.shape[0]), 4))
    _qmul_kernel(p2, q2, out)
    return out


def qconj_batch(q: np.ndarray) -> np.ndarray:
    out = np.array(q, dtype=float, copy=True)
    out[..., 1:] *= -1.0
    return out


def normalize_batch(q: np.ndarray) -> np.ndarray:
    q = np.asarray(q, dtype=float)
    return q / np.linalg.norm(q, axis=-1, keepdims=True)



def _as_rows(a, ncols: int, what: str) -> tuple[np.ndarray, bool]:
    """``a`` as a C-contiguous float64 (N, ncols) array, and whether it was a single row."""
    try:
        arr = np.asarray(a, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{what}: not numeric ({exc})") from None
    if arr.ndim == 1 and arr.shape[0] == ncols:
        return np.ascontiguousarray(arr.reshape(1, ncols)), True
    if arr.ndim != 2 or arr.shape[1] != ncols:
        raise ValueError(f"{what}: expected shape ({ncols},) or (N, {ncols}), got {arr.shape}")
    return np.ascontiguousarray(arr), False



@njit(cache=True, inline="always")
def _qexp_into(vx, vy, vz, out, i):
    angle = math.sqrt(vx * vx + vy * vy + vz * vz)
    half = 0.5 * angle
    if angle < _SMALL_ANGLE:
        # sin(a/2)/a = 1/2 - a^2/48 + ...; cos(a/2) = 1 - a^2/8
        s = 0.5 - angle * angle / 48.0
        c = 1.0 - angle * angle / 8.0
    else:
        s = math.sin(half) / angle
        c = math.cos(half)
    out[i, 0] = c
    out[i, 1] = s * vx
    out[i, 2] = s * vy
    out[i, 3] = s * vz


@njit(cache=True)
def _qexp_kernel(v, out):
    """:func:`_qexp_into` for each row of ``v`` (N, 3) into ``out`` (N, 4)."""
    for i in range(v.shape[0]):
        _qexp_into(v[i, 0], v[i, 1], v[i, 2], out, i)


@njit(cache=True, inline="always")
def _qlog_into(w, x, y, z, out, i):
    if w < 0.0:  # q and -q are the same rotation: take the one with angle in [0, pi]
        w, x, y, z = -w, -x, -y, -z
    nv = math.sqrt(x * x + y * y + z * z)
    if nv < _SMALL_ANGLE:
        # angle = 2 atan2(nv, w) ~ 2 nv / w; scale = angle / nv
        scale = 2.0 / w if w > 0.0 else 0.0
    else:
        scale = 2.0 * math.atan2(nv, w) / nv
    out[i, 0] = scale * x
    out[i, 1] = scale * y
    out[i, 2] = scale * z


@njit(cache=True)
def qexp(v):
    """Unit quaternion of the rotation vector ``v`` (3,), rad: ``(cos(|v|/2), sin(|v|/2) v/|v|)``.

    This is the exponential map of SO(3) written with quaternions, ``exp((0, v/2))``; the rotation
    is by ``|v|`` rad about ``v/|v|``. A Taylor series is used for ``|v| < 1e-8`` rad.
    """
    out = np.empty((1, 4))
    _qexp_into(v[0], v[1], v[2], out, 0)
    return out[0]


@njit(cache=True)
def qlog(q):
    """Rotation vector (3,), rad, of the unit quaternion ``q``: the inverse of :func:`qexp`.

    Returns the shortest rotation (angle in ``[0, pi]``): ``q`` and ``-q`` give the same vector,
    so ``qexp(qlog(q)) == q`` when ``q[0] >= 0`` and ``== -q`` otherwise. ``q`` is not
    renormalised; the angle uses ``atan2(|q_v|, w)``, which tolerates small norm errors.
    """
    out = np.empty((1, 3))
    _qlog_into(q[0], q[1], q[2], q[3], out, 0)
    return out[0]


def qexp_batch(v: np.ndarray) -> np.ndarray:
    """:func:`qexp` row by row: rotation vectors (N, 3) rad -> quaternions (N, 4); (3,) -> (4,)."""
    v2, single = _as_rows(v, 3, "qexp_batch: v")
    out = np.empty((v2.shape[0], 4))
    _qexp_kernel(v2, out)
    return out[0] if single else out


def qlog_batch(q: np.ndarray) -> np.ndarray:
    """:func:`qlog` row by row: quaternions (N, 4) -> rotation vectors (N, 3) rad; (4,) -> (3,).

    Vectorised NumPy rather than a loop over the kernel: NumPy's ``arctan2`` and libm's ``atan2``
    (which numba calls) can differ in the last bit, and the synthetic benches' gyroscope truth
    (:func:`objectives.attitude.data.imu_model.body_rate`) is pinned bit for bit to this form. The
    two agree within 1 ulp of the angle.
    """
    q2, single = _as_rows(q, 4, "qlog_batch: q")
    q2 = np.where(q2[:, :1] < 0, -q2, q2)  # the shorter of q, -q: angle in [0, pi]
    w = q2[:, 0]
    nv = np.linalg.norm(q2[:, 1:], axis=-1)
    safe = np.where(nv > 0, nv, 1.0)
    # angle / |q_v| = 2 atan2(|q_v|, w) / |q_v|; for |q_v| -> 0 (w -> 1) the limit is 2 / w
    scale = np.where(nv < _SMALL_ANGLE, 2.0 / w, 2.0 * np.arctan2(nv, w) / safe)  # NaN rows stay NaN
    out = scale[:, None] * q2[:, 1:]
    return out[0] if single else out


@njit(cache=True)
def _qrot_kernel(q, v, sign, out):
    """Rows of ``out`` (N, 3): ``q * v * conj(q)`` with the vector part of ``q`` times ``sign`` (+-1)."""
    for i in range(out.shape[0]):
        a = i if q.shape[0] > 1 else 0
        b = i if v.shape[0] > 1 else 0
        _qrot_into(q[a, 0], sign * q[a, 1], sign * q[a, 2], sign * q[a, 3], v[b, 0], v[b, 1], v[b, 2], out, i)


def qrot_batch(q: np.ndarray, v: np.ndarray, inverse: bool = False) -> np.ndarray:
    """Rotate vectors by unit quaternions row by row (:func:`qrot`); either side may be one row.

    Parameters
    ----------
    q : ndarray (N, 4) or (4,)
        Unit quaternions ``(w, x, y, z)``.
    v : ndarray (N, 3) or (3,)
        Vectors.
    inverse : bool
        False: ``q * v * conj(q)`` (sensor -> earth for a sensor-to-earth ``q``);
        True: ``conj(q) * v * q`` (earth -> sensor).

    Returns
    -------
    ndarray (N, 3), or (3,) when both inputs are single rows.
    """
    q2, q_single = _as_rows(q, 4, "qrot_batch: q")
    v2, v_single = _as_rows(v, 3, "qrot_batch: v")
    if q2.shape[0] != v2.shape[0] and 1 not in (q2.shape[0], v2.shape[0]):
        raise ValueError(f"qrot_batch: q has {q2.shape[0]} rows, v has {v2.shape[0]}; need equal counts or one row")
    out = np.empty((max(q2.shape[0], v2.shape[0]), 3))
    _qrot_kernel(q2, v2, -1.0 if inverse else 1.0, out)
    return out[0] if q_single and v_single else out


def make_continuous(q: np.ndarray) -> np.ndarray:
    """Flip signs of (N, 4) quaternions so that consecutive rows have a non-negative dot product.

    ``q`` and ``-q`` are the same rotation; a sign-continuous sequence can be differenced and
    interpolated. The first row keeps its sign.
    """
    q = np.asarray(q, dtype=float)
    if q.ndim != 2 or q.shape[1] != 4:
        raise ValueError(f"make_continuous: expected shape (N, 4), got {q.shape}")
    d = np.einsum("ij,ij->i", q[1:], q[:-1])
    flips = np.concatenate([[False], d < 0])
    sign = np.where(np.cumsum(flips) % 2 == 1, -1.0, 1.0)
    return q * sign[:, None]
