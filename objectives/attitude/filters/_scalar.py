"""Scalar building blocks shared by the numba filter kernels (Madgwick, Mahony, complementary, realtime,
Valenti, the UKFs).

Each helper works on plain floats and returns a tuple of floats (and a bool), and is compiled with
``inline="always"``: numba inlines it into the calling kernel before type inference, so the kernel
is compiled as one function with the same operations in the same order as if the lines were written
out in place (results and speed are unchanged).

Sample validity follows one rule everywhere: a vector is usable when its squared norm ``n``
satisfies ``0 < n < inf`` (false for zero, infinite and NaN components).
"""

from __future__ import annotations

import math

from numba import njit

__all__ = ["read_vec", "read_rate", "sq_norm_ok", "unit", "read_unit", "rotate_sensor_to_earth", "qmul"]

@njit(cache=True, inline="always")
def read_vec(a, i):
    """Row ``i`` of an (N, 3) array as ``(x, y, z, ok)``; ``ok``: all three components finite."""
    x = a[i, 0]
    y = a[i, 1]
    z = a[i, 2]
    return x, y, z, math.isfinite(x) and math.isfinite(y) and math.isfinite(z)


@njit(cache=True, inline="always")
def read_rate(a, i):
    """Row ``i`` of an (N, 3) gyroscope array, or ``(0, 0, 0)`` when a component is not finite."""
    x, y, z, ok = read_vec(a, i)
    if not ok:
        return 0.0, 0.0, 0.0
    return x, y, z


@njit(cache=True, inline="always")
def sq_norm_ok(x, y, z):
    """``(n, ok)``: the squared norm ``n = x^2 + y^2 + z^2`` and ``ok = 0 < n < inf``."""
    n = x * x + y * y + z * z
    return n, n > 0.0 and n < math.inf


@njit(cache=True, inline="always")
def unit(x, y, z):
    """``(x, y, z) / |(x, y, z)|`` and True, or the input unchanged and False (zero or non-finite norm)."""
    n, ok = sq_norm_ok(x, y, z)
    if ok:
        r = 1.0 / math.sqrt(n)
        return x * r, y * r, z * r, True
    return x, y, z, False


@njit(cache=True, inline="always")
def read_unit(a, i):
    """Row ``i`` of an (N, 3) array normalised, as :func:`unit` (``ok`` False: not usable)."""
    return unit(a[i, 0], a[i, 1], a[i, 2])


@njit(cache=True, inline="always")
def rotate_sensor_to_earth(q0, q1, q2, q3, x, y, z):
    """``(hx, hy, hz)``: the sensor-frame vector ``(x, y, z)`` in the earth frame, ``h = q v q*``.

    ``q = (q0, q1, q2, q3)`` is the unit sensor-to-earth quaternion (w, x, y, z); the rotation
    matrix is written out as in the 2010 C code of Madgwick's and Mahony's filters (report eq. 45).
    """
    hx = (x * (1.0 - 2.0 * (q2 * q2 + q3 * q3)) + 2.0 * y * (q1 * q2 - q0 * q3)
          + 2.0 * z * (q1 * q3 + q0 * q2))
    hy = (2.0 * x * (q1 * q2 + q0 * q3) + y * (1.0 - 2.0 * (q1 * q1 + q3 * q3))
          + 2.0 * z * (q2 * q3 - q0 * q1))
    hz = (2.0 * x * (q1 * q3 - q0 * q2) + 2.0 * y * (q2 * q3 + q0 * q1)
          + z * (1.0 - 2.0 * (q1 * q1 + q2 * q2)))
    return hx, hy, hz


@njit(cache=True, inline="always")
def qmul(a0, a1, a2, a3, b0, b1, b2, b3):
    """The Hamilton product ``a (x) b`` of two quaternions given by their components (w, x, y, z)."""
    return (a0 * b0 - a1 * b1 - a2 * b2 - a3 * b3,
            a0 * b1 + a1 * b0 + a2 * b3 - a3 * b2,
            a0 * b2 - a1 * b3 + a2 * b0 + a3 * b1,
            a0 * b3 + a1 * b2 - a2 * b1 + a3 * b0)


@njit(cache=True, inline="always")
def normalized_q(n0, n1, n2, n3):
    """``n / |n|`` of a quaternion given by its components (no check: callers keep ``n`` away from 0)."""
    r = 1.0 / math.sqrt(n0 * n0 + n1 * n1 + n2 * n2 + n3 * n3)
    return n0 * r, n1 * r, n2 * r, n3 * r


@njit(cache=True, inline="always")
def store_q_bias(a, q0, q1, q2, q3, b0, b1, b2):
    """Write a quaternion and a 3-vector into ``a[:7]`` (the quaternion-and-bias state of a kernel)."""
    a[0], a[1], a[2], a[3], a[4], a[5], a[6] = q0, q1, q2, q3, b0, b1, b2


@njit(cache=True, inline="always")
def load_q_bias(a):
    """The quaternion and the 3-vector stored by :func:`store_q_bias`."""
    return a[0], a[1], a[2], a[3], a[4], a[5], a[6]


@njit(cache=True, inline="always")
def write_vec(a, i, x, y, z):
    """``a[i, :3] = (x, y, z)``."""
    a[i, 0], a[i, 1], a[i, 2] = x, y, z


@njit(cache=True, inline="always")
def write_q(a, i, q0, q1, q2, q3):
    """``a[i, :4] = (q0, q1, q2, q3)``."""
    a[i, 0], a[i, 1], a[i, 2], a[i, 3] = q0, q1, q2, q3
