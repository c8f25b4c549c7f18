"""Numba kernel of Mahony's filter (:mod:`objectives.attitude.filters.mahony`): the per-sample recursion, the
kernel over whole arrays and its coefficient layout.

Layouts: the coefficient array is :data:`C` (this filter's own entries), followed with a robust block on by the
shared blocks' part (:data:`objectives.attitude.filters._bias_filter.RC`); the state is the shared
:data:`objectives.attitude.filters._bias_filter.S` (quaternion and integral, then the blocks' states).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from objectives.attitude.filters import _scalar as sc
from objectives.attitude.filters._bias_filter import bias_kernel_loop, with_robust
from objectives.attitude.filters.layout import Layout

__all__ = ["C", "coefficients", "mahony_kernel", "mahony_kernel_inner"]

#: the filter's own coefficients (the robust blocks' follow from ``_bias_filter.ROBUST_AT`` when one is on)
C = Layout("C", (("DT", 1, "sample time, s"),
                 ("KP", 1, "proportional gain, rad/s (TAC 2008 eq. 32 k_P)"),
                 ("KI", 1, "integral gain, rad/s^2 (TAC 2008 eq. 32 k_I)"),
                 ("USE_MAG", 1, "1: MARG, 0: IMU")))


@njit(cache=True, inline="always")
def _update(q0_, q1, q2, q3, ix, iy, iz, gx, gy, gz, ax, ay, az, acc_ok, mx, my, mz, mag_ok, gm, gains):
    """One sample from the estimate ``q`` and integral ``I``: the new ``(q, I)`` (module docstring: predicted
    gravity and field directions, the cross-product error, PI feedback, first-order integration); ``gm``
    scales the magnetometer's error term (1: the C code; below 1: a field block a finds disturbed), ``gains``
    is ``(dt, kp, ki)``. The kernel's one recursion, with the robust blocks on or off.
    """
    dt, kp, ki = gains
    if acc_ok:
        # predicted gravity direction v_hat = R(q)^T (0, 0, 1)
        vx = 2.0 * (q1 * q3 - q0_ * q2)
        vy = 2.0 * (q0_ * q1 + q2 * q3)
        vz = q0_ * q0_ - q1 * q1 - q2 * q2 + q3 * q3
        # omega_mes = a x v_hat
        ex = ay * vz - az * vy
        ey = az * vx - ax * vz
        ez = ax * vy - ay * vx
        if mag_ok:
            # earth-field reference b = (|h_xy|, 0, h_z), h = q (x) m (x) q*; predicted w_hat = R(q)^T b
            hx, hy, bz = sc.rotate_sensor_to_earth(q0_, q1, q2, q3, mx, my, mz)
            bx = math.sqrt(hx * hx + hy * hy)
            wx = 2.0 * gm * (bx * (0.5 - q2 * q2 - q3 * q3) + bz * (q1 * q3 - q0_ * q2))
            wy = 2.0 * gm * (bx * (q1 * q2 - q0_ * q3) + bz * (q0_ * q1 + q2 * q3))
            wz = 2.0 * gm * (bx * (q0_ * q2 + q1 * q3) + bz * (0.5 - q1 * q1 - q2 * q2))
            ex += my * wz - mz * wy
            ey += mz * wx - mx * wz
            ez += mx * wy - my * wx
        if ki > 0.0:
            ix += ki * ex * dt
            iy += ki * ey * dt
            iz += ki * ez * dt
        else:
            ix = 0.0
            iy = 0.0
            iz = 0.0
        gx += kp * ex
        gy += kp * ey
        gz += kp * ez
    h = 0.5 * dt
    gx = (gx + ix) * h
    gy = (gy + iy) * h
    gz = (gz + iz) * h
    n0 = q0_ + (-q1 * gx - q2 * gy - q3 * gz)
    n1 = q1 + (q0_ * gx + q2 * gz - q3 * gy)
    n2 = q2 + (q0_ * gy - q1 * gz + q3 * gx)
    n3 = q3 + (q0_ * gz + q1 * gy - q2 * gx)
    q0_, q1, q2, q3 = sc.normalized_q(n0, n1, n2, n3)
    return q0_, q1, q2, q3, ix, iy, iz


@njit
def mahony_kernel_inner(gyr, acc, mag, coef, state, out, bias_out):
    """Mahony filter over whole arrays (module docstring): the arrays of
    :func:`~objectives.attitude.filters._bias_filter.bias_kernel_loop`, with ``coef`` in layout :data:`C`
    (``dt`` s, ``Kp`` rad/s per unit error, ``Ki`` rad/s^2 per unit error, ``use_mag`` 0 or 1) and as the bias
    state the integral ``I`` (rad/s), the gyro bias estimate ``b = -I`` after each sample's update."""
    # the bias used at a sample: the integral after its update, plus the rest bias (bias_after)
    bias_kernel_loop(_update, True, (coef[C.DT], coef[C.KP], coef[C.KI]), gyr, acc, mag, coef, state, out, bias_out,
                     coef[C.USE_MAG])


@njit(cache=True)
def mahony_kernel(gyr, acc, mag, coef, state, out, bias_out):
    """:func:`mahony_kernel_inner`, cached: the entry Python calls. The population kernel calls the uncached body
    itself (rule 2 of :mod:`objectives.jit`), so a process compiles it once, not once more for a twin."""
    mahony_kernel_inner(gyr, acc, mag, coef, state, out, bias_out)


def coefficients(v: dict, dt: float, has_mag: bool) -> np.ndarray:
    """The kernel's coefficient array from validated values (the only place it is built)."""
    return with_robust(C.pack(DT=dt, KP=float(v["Kp"]), KI=float(v["Ki"]), USE_MAG=1.0 if has_mag else 0.0), v, dt)
