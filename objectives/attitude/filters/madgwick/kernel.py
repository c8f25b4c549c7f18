"""Numba kernel of Madgwick's filter (:mod:`objectives.attitude.filters.madgwick`): the per-sample recursion
(report eqs. 11-13, 25-34, 42-49), the kernel over whole arrays and its coefficient layout.

Layouts: the coefficient array is :data:`C` (this filter's own entries), followed with a robust block on by the
shared blocks' part (:data:`objectives.attitude.filters._bias_filter.RC`); the state is the shared
:data:`objectives.attitude.filters._bias_filter.S` (quaternion and bias, then the blocks' states).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from objectives.attitude.filters import _scalar as sc
from objectives.attitude.filters._bias_filter import bias_kernel_loop, with_robust
from objectives.attitude.filters.layout import Layout

__all__ = ["C", "VARIANTS", "coefficients", "madgwick_kernel", "madgwick_kernel_inner"]

#: name -> factor k with ``2 b_x = k |h_xy|``, ``2 b_z = k h_z`` (paper: 2; the 2010 C code: 1)
VARIANTS = {"paper": 2.0, "original_c": 1.0}

#: the filter's own coefficients (the robust blocks' follow from ``_bias_filter.ROBUST_AT`` when one is on)
C = Layout("C", (("DT", 1, "sample time, s"),
                 ("BETA", 1, "gradient step gain, rad/s (report eq. 33)"),
                 ("ZETA", 1, "gyro bias drift gain, 1/s (report eq. 48)"),
                 ("FIELD_K", 1, "field scale k of VARIANTS (report eqs. 45-46)"),
                 ("USE_MAG", 1, "1: MARG, 0: IMU")))


@njit(cache=True, inline="always")
def _update(q0_, q1, q2, q3, bx_, by_, bz_, gx, gy, gz, ax, ay, az, acc_ok, mx, my, mz, mag_ok, gm, gains):
    """One sample of the filter from the estimate ``q`` and bias ``b``: the new ``(q, b)`` (report eqs. 11-13,
    25-34, 42-49); ``gm`` scales the magnetometer's error (1: the paper; below 1: a field block a finds
    disturbed), ``gains`` is ``(dt, beta, zeta, k)``. The kernel's one recursion, with the robust blocks on or off.
    """
    dt, beta, zeta, k = gains
    # eq. 49: bias-compensated rate
    gx -= bx_
    gy -= by_
    gz -= bz_
    # eq. 12: rate of change from the gyroscope, q_dot = 0.5 q (x) (0, w)
    qd0 = 0.5 * (-q1 * gx - q2 * gy - q3 * gz)
    qd1 = 0.5 * (q0_ * gx + q2 * gz - q3 * gy)
    qd2 = 0.5 * (q0_ * gy - q1 * gz + q3 * gx)
    qd3 = 0.5 * (q0_ * gz + q1 * gy - q2 * gx)
    if acc_ok:
        # eq. 25: f_g = R(q)^T (0, 0, 1) - a
        f1 = 2.0 * (q1 * q3 - q0_ * q2) - ax
        f2 = 2.0 * (q0_ * q1 + q2 * q3) - ay
        f3 = 1.0 - 2.0 * (q1 * q1 + q2 * q2) - az
        # eq. 34: J_g^T f_g (J_g of eq. 26)
        s0 = -2.0 * q2 * f1 + 2.0 * q1 * f2
        s1 = 2.0 * q3 * f1 + 2.0 * q0_ * f2 - 4.0 * q1 * f3
        s2 = -2.0 * q0_ * f1 + 2.0 * q3 * f2 - 4.0 * q2 * f3
        s3 = 2.0 * q1 * f1 + 2.0 * q2 * f2
        if mag_ok:
            # eq. 45: h = q (x) m (x) q*
            hx, hy, hz = sc.rotate_sensor_to_earth(q0_, q1, q2, q3, mx, my, mz)
            # eq. 46 (paper: k = 2) or the C code's half-length field (k = 1)
            tbx = k * math.sqrt(hx * hx + hy * hy)  # 2 b_x
            tbz = k * hz  # 2 b_z
            # eq. 29: f_b = R(q)^T b - m
            e1 = tbx * (0.5 - q2 * q2 - q3 * q3) + tbz * (q1 * q3 - q0_ * q2) - mx
            e2 = tbx * (q1 * q2 - q0_ * q3) + tbz * (q0_ * q1 + q2 * q3) - my
            e3 = tbx * (q0_ * q2 + q1 * q3) + tbz * (0.5 - q1 * q1 - q2 * q2) - mz
            if gm != 1.0:  # a disturbed field (mag_rejection): its gradient scaled by the block's gain
                e1 *= gm
                e2 *= gm
                e3 *= gm
            # eq. 34: + J_b^T f_b (J_b of eq. 30)
            s0 += -tbz * q2 * e1 + (-tbx * q3 + tbz * q1) * e2 + tbx * q2 * e3
            s1 += tbz * q3 * e1 + (tbx * q2 + tbz * q0_) * e2 + (tbx * q3 - 2.0 * tbz * q1) * e3
            s2 += ((-2.0 * tbx * q2 - tbz * q0_) * e1 + (tbx * q1 + tbz * q3) * e2
                   + (tbx * q0_ - 2.0 * tbz * q2) * e3)
            s3 += (-2.0 * tbx * q3 + tbz * q1) * e1 + (-tbx * q0_ + tbz * q2) * e2 + tbx * q1 * e3
        sn = s0 * s0 + s1 * s1 + s2 * s2 + s3 * s3
        if sn > 0.0 and sn < math.inf:
            r = 1.0 / math.sqrt(sn)
            s0 *= r
            s1 *= r
            s2 *= r
            s3 *= r
            # eq. 42-43: q_dot = q_dot_w - beta * grad / |grad|
            qd0 -= beta * s0
            qd1 -= beta * s1
            qd2 -= beta * s2
            qd3 -= beta * s3
            if zeta != 0.0:
                # eqs. 47-48: w_eps = 2 q* (x) q_dot_eps, w_b += zeta w_eps dt
                c = 2.0 * zeta * dt
                bx_ += c * (q0_ * s1 - q1 * s0 - q2 * s3 + q3 * s2)
                by_ += c * (q0_ * s2 + q1 * s3 - q2 * s0 - q3 * s1)
                bz_ += c * (q0_ * s3 - q1 * s2 + q2 * s1 - q3 * s0)
    # eq. 13 (Euler step) and normalisation
    n0 = q0_ + qd0 * dt
    n1 = q1 + qd1 * dt
    n2 = q2 + qd2 * dt
    n3 = q3 + qd3 * dt
    q0_, q1, q2, q3 = sc.normalized_q(n0, n1, n2, n3)
    return q0_, q1, q2, q3, bx_, by_, bz_


@njit
def madgwick_kernel_inner(gyr, acc, mag, coef, state, out, bias_out):
    """Madgwick filter over whole arrays (report eqs. 11-13, 25-34, 42-49): the arrays of
    :func:`~objectives.attitude.filters._bias_filter.bias_kernel_loop`, with ``coef`` in layout :data:`C`
    (``dt`` s, ``beta`` rad/s (eq. 33), ``zeta`` rad/s^2 per unit error (eq. 48), ``k`` the field-scale factor
    of ``VARIANTS``, ``use_mag`` 0 or 1) and as the bias state the gyro bias estimate ``omega_b`` (eq. 48),
    written to ``bias_out`` as used at each sample."""
    gains = (coef[C.DT], coef[C.BETA], coef[C.ZETA], coef[C.FIELD_K])
    bias_kernel_loop(_update, False, gains, gyr, acc, mag, coef, state, out, bias_out, coef[C.USE_MAG])


@njit(cache=True)
def madgwick_kernel(gyr, acc, mag, coef, state, out, bias_out):
    """:func:`madgwick_kernel_inner`, cached: the entry Python calls. The population kernel calls the uncached body
    itself (rule 2 of :mod:`objectives.jit`), so a process compiles it once, not once more for a twin."""
    madgwick_kernel_inner(gyr, acc, mag, coef, state, out, bias_out)


def coefficients(v: dict, dt: float, has_mag: bool) -> np.ndarray:
    """The kernel's coefficient array from validated values (the only place it is built)."""
    coef = C.pack(DT=dt, BETA=float(v["beta"]), ZETA=float(v["zeta"]), FIELD_K=VARIANTS[v["variant"]],
                  USE_MAG=1.0 if has_mag else 0.0)
    return with_robust(coef, v, dt)
