"""The per-sample steps of the complementary filters (Narkhede et al. 2021), inlined into the one recursion of
:mod:`objectives.attitude.filters.complementary.kernel` (the paper's, and with the robust blocks): angle wrap,
magnetometer read and yaw (eq. 6), PI step (eqs. 10, 12), blend (eqs. 8, 14), Z-Y-X quaternion.
"""

from __future__ import annotations

import math

from numba import njit

from objectives.attitude.filters._scalar import read_vec, sq_norm_ok

_PI = math.pi
_TWO_PI = 2.0 * math.pi


@njit(cache=True, inline="always")
def _wrap(a):
    """Angle wrapped to [-pi, pi). Below 3 in magnitude ``(a + pi) / (2 pi)`` lies in (0.02, 0.98), its floor is 0
    and the formula returns ``a`` itself (``a - 0.0``), so the angle is returned without the division, as the C
    port's ``wrap_`` does: the same bits, and most calls skip a division on the sample's critical path."""
    if abs(a) < 3.0:
        return a
    return a - _TWO_PI * math.floor((a + _PI) / _TWO_PI)


@njit(cache=True, inline="always")
def _read_mag(mag, i, use_mag):
    """Row ``i`` of the magnetometer as ``(mx, my, mz, ok)``; ``ok`` False when unused or unusable."""
    if use_mag:
        mx, my, mz, _ = read_vec(mag, i)
        _, ok = sq_norm_ok(mx, my, mz)
        return mx, my, mz, ok
    return 0.0, 0.0, 0.0, False


@njit(cache=True, inline="always")
def _mag_yaw(mx, my, mz, sphi, cphi, sth, cth):
    """Tilt-compensated magnetometer yaw of eq. (6) at roll/pitch given by their sines and cosines."""
    return math.atan2(mz * sphi - my * cphi, mx * cth + my * sth * sphi + mz * sth * cphi)


@njit(cache=True, inline="always")
def _pi_step(e, integ, rate, kp, ki, dt):
    """Eqs. (10), (12) for one angle: ``(I + Ki e dt, rate + Kp e)``."""
    return integ + ki * e * dt, rate + kp * e


@njit(cache=True, inline="always")
def _blend(x, target, w):
    """Eqs. (8), (14): ``x + w wrap(target - x)``."""
    return x + w * _wrap(target - x)


@njit(cache=True, inline="always")
def _quat_zyx(phi, th, psi):
    """``q = q_z(psi) q_y(theta) q_x(phi)`` as ``(w, x, y, z)``."""
    c1 = math.cos(0.5 * phi)
    s1 = math.sin(0.5 * phi)
    c2 = math.cos(0.5 * th)
    s2 = math.sin(0.5 * th)
    c3 = math.cos(0.5 * psi)
    s3 = math.sin(0.5 * psi)
    return (c1 * c2 * c3 + s1 * s2 * s3, s1 * c2 * c3 - c1 * s2 * s3,
            c1 * s2 * c3 + s1 * c2 * s3, c1 * c2 * s3 - s1 * s2 * c3)
