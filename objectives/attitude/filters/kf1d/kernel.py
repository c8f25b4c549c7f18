"""Numba kernels of the 1-D tilt filters (thesis section 3.1) and their layouts; the classes, equations and
conventions are in :mod:`objectives.attitude.filters.kf1d`. Each kernel takes and returns its state, so the
batch run and the per-sample stream run the same code.

Layouts (declared once): the tilt KF's coefficients :data:`C` and state :data:`X`; the sample-code filters'
gains :data:`MAHONY_C` and :data:`MADGWICK_C` (the kernels take them as scalars) and state :data:`T`."""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from objectives.attitude.filters.layout import Layout
from objectives.jit import uncached

__all__ = ["C", "X", "MAHONY_C", "MADGWICK_C", "T", "kf1d_kernel", "mahony1d_kernel", "madgwick1d_kernel",
           "tilt_state", "quat_from_tilt_kernel", "change_starts"]

_TWO_PI = 2.0 * math.pi

#: the tilt KF's coefficients (eqs. 3.11, 3.17)
C = Layout("C", (("DT", 1, "sample time Ts, s"), ("Q00", 1, "angle process noise per sample"),
                 ("Q11", 1, "bias random walk per sample"), ("RHO", 1, "accelerometer-angle variance per sample")))
#: the tilt KF's state: angle, bias and covariance (eqs. 3.9-3.13)
X = Layout("X", (("THETA", 1, "tilt angle about y, rad"), ("BIAS", 1, "gyro bias, rad/s"),
                 ("P00", 1, "covariance"), ("P01", 1), ("P11", 1)))
#: the 1-D Mahony's gains and the 1-D Madgwick's
MAHONY_C = Layout("C", (("DT", 1, "s"), ("KP", 1, "rad/s"), ("KI", 1, "rad/s^2")))
MADGWICK_C = Layout("C", (("DT", 1, "s"), ("BETA", 1, "rad/s")))
#: their state: the half-angle quaternion (q0, q2) about y and the integral (Mahony)
T = Layout("T", (("Q0", 1, "cos(theta/2)"), ("Q2", 1, "sin(theta/2)"), ("INTEG", 1, "Mahony's integral, rad/s")))


# --- kernels -------------------------------------------------------------------------------------
@njit(cache=True)
def kf1d_kernel(gyr_y, acc_x, acc_z, up_sign, coef, kscale, state, k_start, out_theta, out_bias):
    """2-state tilt KF (thesis eqs. 3.9-3.13) over whole arrays.

    Parameters
    ----------
    gyr_y : (N,) rate about y, rad/s.
    acc_x, acc_z : (N,) specific force x and z, any unit.
    up_sign : +1.0 (z-up earth frame) or -1.0 (NED).
    coef : (C.LEN,) ``dt, q00, q11, rho`` (layout :data:`C`).
    kscale : (N,) scale of R per sample (AKF1D), or (1,) constant scale (KF1D: ones(1)).
    state : (X.LEN,) in/out: ``theta, bias, P00, P01, P11`` (layout :data:`X`) after sample ``k_start - 1``; the
        batch starts from ``(theta0, 0, p0_theta, 0, p0_bias)`` at sample 0, a stream carries it between calls.
    k_start : first sample to update (1 in the batch and for a stream's (previous, current) pair).
    out_theta, out_bias : (N,) outputs, rad and rad/s (rows ``k_start - 1 ..``).
    """
    n = gyr_y.shape[0]
    dt = coef[C.DT]
    q00 = coef[C.Q00]
    q11 = coef[C.Q11]
    rho = coef[C.RHO]
    th = state[X.THETA]
    b = state[X.BIAS]
    p00 = state[X.P00]
    p01 = state[X.P01]
    p11 = state[X.P11]
    per_sample = kscale.shape[0] > 1
    r = rho * kscale[0]
    out_theta[k_start - 1] = th
    out_bias[k_start - 1] = b
    dt2 = dt * dt
    for k in range(k_start, n):
        # time update (3.11)
        th += dt * (gyr_y[k - 1] - b)
        m00 = p00 - 2.0 * dt * p01 + dt2 * p11 + q00
        m01 = p01 - dt * p11
        m11 = p11 + q11
        # measurement update (3.12, 3.13)
        if per_sample:
            r = rho * kscale[k]
        z = math.atan2(-up_sign * acc_x[k], up_sign * acc_z[k])
        res = z - th
        if res > math.pi or res < -math.pi:
            res -= _TWO_PI * math.floor((res + math.pi) / _TWO_PI)
        s = m00 + r
        g0 = m00 / s
        g1 = m01 / s
        th += g0 * res
        b += g1 * res
        p00 = (1.0 - g0) * m00
        p01 = (1.0 - g0) * m01
        p11 = m11 - g1 * m01
        out_theta[k] = th
        out_bias[k] = b
    state[X.THETA] = th
    state[X.BIAS] = b
    state[X.P00] = p00
    state[X.P01] = p01
    state[X.P11] = p11


#: the uncached twin other kernels call (objectives.jit)
kf1d_kernel_inner = uncached(kf1d_kernel)


@njit(cache=True, inline="always")
def _step(q0, q2, w, dt, exact):
    """Rotate (q0, q2) by the rate w about y over dt: exact or the first-order quaternion step."""
    if exact:
        c = math.cos(0.5 * w * dt)
        s = math.sin(0.5 * w * dt)
        return c * q0 - s * q2, s * q0 + c * q2
    h = 0.5 * w * dt
    return q0 - h * q2, q2 + h * q0


@njit(cache=True, inline="always")
def _unit_acc(acc_x, acc_z, up_sign, k):
    """Sample ``k``'s specific force in the x-z plane (times ``up_sign``), normalised, and whether it is
    usable (norm > 0; otherwise returned as read)."""
    ax = up_sign * acc_x[k]
    az = up_sign * acc_z[k]
    nrm = math.sqrt(ax * ax + az * az)
    if nrm > 0.0:
        return ax / nrm, az / nrm, True
    return ax, az, False


@njit(cache=True, inline="always")
def _emit_tilt(q0, q2, out_theta, i):
    """Normalise ``(q0, q2)``, write its angle ``2 atan2(q2, q0)`` (rad) as ``out_theta[i]``, return it."""
    inv = 1.0 / math.sqrt(q0 * q0 + q2 * q2)
    q0 *= inv
    q2 *= inv
    out_theta[i] = 2.0 * math.atan2(q2, q0)
    return q0, q2


@njit(cache=True)
def mahony1d_kernel(gyr_y, acc_x, acc_z, up_sign, kp, ki, dt, state, exact, out_theta, out_bias):
    """Mahony's IMU update (sample code) restricted to rotations about y; see the module docstring.

    ``out_bias`` receives ``-I`` (the integral term estimates minus the gyro bias), rad/s. Rows
    ``1..N-1`` are written (row 0 is the state before the first sample); ``state`` (3,) in/out holds
    ``(q0, q2, I)`` before the first and after the last sample (:func:`tilt_state` starts it).
    """
    n = gyr_y.shape[0]
    q0 = state[T.Q0]
    q2 = state[T.Q2]
    integ = state[T.INTEG]
    for k in range(n - 1):
        w = gyr_y[k]
        ax, az, acc_ok = _unit_acc(acc_x, acc_z, up_sign, k)
        if acc_ok:
            vx = -2.0 * q0 * q2           # estimated up direction (sample code: halfv * 2)
            vz = q0 * q0 - q2 * q2
            e = az * vx - ax * vz          # y component of a x v
            if ki > 0.0:
                integ += ki * e * dt
                w += integ
            else:
                integ = 0.0
            w += kp * e
        q0, q2 = _step(q0, q2, w, dt, exact)
        q0, q2 = _emit_tilt(q0, q2, out_theta, k + 1)
        out_bias[k + 1] = -integ
    state[T.Q0] = q0
    state[T.Q2] = q2
    state[T.INTEG] = integ


@njit(cache=True)
def madgwick1d_kernel(gyr_y, acc_x, acc_z, up_sign, beta, dt, state, exact, out_theta):
    """Madgwick's IMU update (sample code) restricted to rotations about y; see the module docstring.

    Rows ``1..N-1`` of ``out_theta`` are written; ``state`` (at least 2,) in/out holds ``(q0, q2)``.
    """
    n = gyr_y.shape[0]
    q0 = state[T.Q0]
    q2 = state[T.Q2]
    for k in range(n - 1):
        w = gyr_y[k]
        ax, az, acc_ok = _unit_acc(acc_x, acc_z, up_sign, k)
        d0 = 0.0
        d2 = 0.0
        if acc_ok:
            # gradient J^T f of the sample code with q1 = q3 = 0 and ay = 0
            s0 = 4.0 * q0 * q2 * q2 + 2.0 * q2 * ax
            s2 = 4.0 * q0 * q0 * q2 + 2.0 * q0 * ax - 4.0 * q2 + 8.0 * q2 * q2 * q2 + 4.0 * q2 * az
            sn = math.sqrt(s0 * s0 + s2 * s2)
            if sn > 0.0:
                d0 = -beta * s0 / sn
                d2 = -beta * s2 / sn
        if exact:
            q0, q2 = _step(q0, q2, w, dt, True)
            q0 += d0 * dt
            q2 += d2 * dt
        else:
            q0, q2 = q0 + (-0.5 * q2 * w + d0) * dt, q2 + (0.5 * q0 * w + d2) * dt
        q0, q2 = _emit_tilt(q0, q2, out_theta, k + 1)
    state[T.Q0] = q0
    state[T.Q2] = q2


@njit(cache=True)
def tilt_state(theta0, state):
    """``state = (cos(theta0/2), sin(theta0/2), 0)`` (layout :data:`T`): the start of the Mahony/Madgwick 1-D
    kernels."""
    state[T.Q0] = math.cos(0.5 * theta0)
    state[T.Q2] = math.sin(0.5 * theta0)
    state[T.INTEG] = 0.0


@njit(cache=True)
def quat_from_tilt_kernel(theta, out):
    """``out[k] = (cos(theta[k]/2), 0, sin(theta[k]/2), 0)``: the rotations about y by the angles (N,), rad."""
    for k in range(theta.shape[0]):
        h = 0.5 * theta[k]
        out[k, 0] = math.cos(h)
        out[k, 1] = 0.0
        out[k, 2] = math.sin(h)
        out[k, 3] = 0.0


#: the uncached twin other kernels call (objectives.jit)
quat_from_tilt_inner = uncached(quat_from_tilt_kernel)


@njit(cache=True)
def change_starts(a, b):
    """The indices where the pair ``(a[i], b[i])`` differs from the one before (0 first; NaN differs from
    everything, as ``!=``): the starts of the piecewise-constant runs the AKF's fuzzy scale is held over."""
    n = a.shape[0]
    out = np.empty(n, dtype=np.int64)
    m = 0
    for i in range(n):
        if i == 0 or a[i] != a[i - 1] or b[i] != b[i - 1]:
            out[m] = i
            m += 1
    return out[:m]
