"""Numba kernel of the quaternion EKF / FAEKF (FAEKF paper eqs. 16-22, 36, 31).

The filter classes, parameter declarations and the fuzzy scaling live in
:mod:`objectives.attitude.filters.ekf`; see its docstring for the equations and deviations.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from objectives.attitude.quaternion import _triad_into

__all__ = ["ekf_kernel", "ekf_steps", "N_COEF"]


# indices into the coefficient array of the kernel
_C_DT, _C_QQ, _C_QW, _C_RHO, _C_P0Q, _C_P0B, _C_MAG, _C_EXACT, _C_GATE, _C_G, _C_HUBER, _C_CUR = range(12)
N_COEF = 12


# ---------------------------------------------------------------------------------------------
# numba kernels
# ---------------------------------------------------------------------------------------------
@njit(cache=True)
def ekf_kernel(gyr, acc, mag, coef, kscale, x0, out_q, out_b):
    """Run the EKF / FAEKF over a whole recording (eqs. 16-22, 36; ``R_k = K_k R`` of eq. 31).

    Parameters
    ----------
    gyr, acc, mag : (N, 3) float64
        rad/s, specific force (any unit), magnetic field (any unit; ignored if ``coef[6] == 0``).
    coef : (8,) to (12,) float64
        ``dt`` (s), ``q_q``, ``q_w``, ``rho``, ``p0_q``, ``p0_b`` (initial variances), ``use_mag``,
        ``exact`` (1: exponential quaternion step, 0: the first-order step of eq. 16); optional:
        ``acc_gate`` (relative, inf: off), ``g`` (gravity in acc units), ``huber`` (rad, inf: off),
        ``current`` (1: gyro sample ``k`` propagates ``k-1 -> k``; 0: sample ``k-1``).
    kscale : (N,) or (1,) float64
        Per-sample scale ``K_k`` of ``R`` (FAEKF), or a single constant (1.0 for the EKF).
    x0 : (7,) float64
        Initial state: NED sensor-to-earth quaternion and gyro bias (rad/s).
    out_q : (N, 4) float64, out
        Normalised quaternion estimates, NED sensor-to-earth.
    out_b : (N, 3) float64, out
        Gyro bias estimates, rad/s.
    """
    P = np.zeros((7, 7))
    for i in range(4):
        P[i, i] = coef[_C_P0Q]
    for i in range(4, 7):
        P[i, i] = coef[_C_P0B]
    x = np.empty(7)
    for i in range(7):
        x[i] = x0[i]
    nq = math.sqrt(x[0] * x[0] + x[1] * x[1] + x[2] * x[2] + x[3] * x[3])
    for i in range(4):
        x[i] /= nq
        out_q[0, i] = x[i]
    for i in range(3):
        out_b[0, i] = x[4 + i]
    ekf_steps(gyr, acc, mag, coef, kscale, x, P, 1, out_q, out_b)


@njit(cache=True)
def ekf_steps(gyr, acc, mag, coef, kscale, x, P, k_start, out_q, out_b):
    """The time and measurement updates of samples ``k_start .. N-1`` from the state ``(x, P)``.

    :func:`ekf_kernel` calls it from sample 1 after writing the initial state as sample 0; a stream
    calls it with ``k_start = 1`` on two-sample arrays (previous, current sample) per update.

    Parameters
    ----------
    gyr, acc, mag, coef, kscale, out_q, out_b
        As :func:`ekf_kernel` (rows ``k_start..N-1`` of the outputs are written).
    x : (7,) float64, in/out
        State after sample ``k_start - 1``: unit NED quaternion and gyro bias, rad/s.
    P : (7, 7) float64, in/out
        Its covariance.
    """
    n = gyr.shape[0]
    h = 0.5 * coef[_C_DT]
    qq = coef[_C_QQ]
    qw = coef[_C_QW]
    rho = coef[_C_RHO]
    use_mag = coef[_C_MAG] != 0.0
    exact = coef[_C_EXACT] != 0.0
    gate = coef[_C_GATE] if coef.shape[0] > _C_GATE else math.inf
    g_ref = coef[_C_G] if coef.shape[0] > _C_G else 1.0
    huber = coef[_C_HUBER] if coef.shape[0] > _C_HUBER else math.inf
    cur = 1 if (coef.shape[0] > _C_CUR and coef[_C_CUR] != 0.0) else 0
    nk = kscale.shape[0]

    A = np.empty((4, 4))
    B = np.empty((4, 3))
    T = np.empty((4, 7))
    W = np.empty((4, 7))
    L = np.zeros((4, 4))
    z = np.empty((1, 4))
    v = np.empty(4)
    for k in range(k_start, n):
        # ---- time update (eqs. 16, 20, 21) with gyro sample k-1 --------------------------------
        q0, q1, q2, q3 = x[0], x[1], x[2], x[3]
        kg = k - 1 + cur
        wx = gyr[kg, 0] - x[4]
        wy = gyr[kg, 1] - x[5]
        wz = gyr[kg, 2] - x[6]
        if exact:
            # q_k = q_{k-1} (x) exp(omega Ts / 2): A = cos(|w| Ts/2) I + sin(|w| Ts/2)/|w| Omega_R(w)
            wn = math.sqrt(wx * wx + wy * wy + wz * wz)
            ang = h * wn
            ca = math.cos(ang)
            sa = h * (math.sin(ang) / ang if ang > 1e-6 else 1.0 - ang * ang / 6.0)
        else:
            # eq. 16: q_k = q_{k-1} + Ts/2 q_{k-1} (x) (0, omega)
            ca = 1.0
            sa = h
        hx, hy, hz = sa * wx, sa * wy, sa * wz
        # A = d q_k / d q_{k-1} = ca I + sa Omega_R(omega)   (q (x) (0, w) = Omega_R(w) q)
        A[0, 0] = ca
        A[0, 1] = -hx
        A[0, 2] = -hy
        A[0, 3] = -hz
        A[1, 0] = hx
        A[1, 1] = ca
        A[1, 2] = hz
        A[1, 3] = -hy
        A[2, 0] = hy
        A[2, 1] = -hz
        A[2, 2] = ca
        A[2, 3] = hx
        A[3, 0] = hz
        A[3, 1] = hy
        A[3, 2] = -hx
        A[3, 3] = ca
        # B = d q_k / d b = -h * Xi(q), q (x) (0, w) = Xi(q) w
        B[0, 0] = h * q1
        B[0, 1] = h * q2
        B[0, 2] = h * q3
        B[1, 0] = -h * q0
        B[1, 1] = h * q3
        B[1, 2] = -h * q2
        B[2, 0] = -h * q3
        B[2, 1] = -h * q0
        B[2, 2] = h * q1
        B[3, 0] = h * q2
        B[3, 1] = -h * q1
        B[3, 2] = -h * q0
        # state: q <- A q (the bias is constant)
        x[0] = ca * q0 - hx * q1 - hy * q2 - hz * q3
        x[1] = ca * q1 + hx * q0 + hz * q2 - hy * q3
        x[2] = ca * q2 + hy * q0 - hz * q1 + hx * q3
        x[3] = ca * q3 + hz * q0 + hy * q1 - hx * q2
        # T = Phi[:4, :] P  (4 x 7); Phi = [[A, B], [0, I]]
        for r in range(4):
            a0, a1, a2, a3 = A[r, 0], A[r, 1], A[r, 2], A[r, 3]
            b0, b1, b2 = B[r, 0], B[r, 1], B[r, 2]
            for c in range(7):
                T[r, c] = (a0 * P[0, c] + a1 * P[1, c] + a2 * P[2, c] + a3 * P[3, c]
                           + b0 * P[4, c] + b1 * P[5, c] + b2 * P[6, c])
        # P^- = T Phi^T + Q: qq block, qb block (= T[:, 4:]), bb block unchanged
        for r in range(4):
            for c in range(r, 4):
                s = (T[r, 0] * A[c, 0] + T[r, 1] * A[c, 1] + T[r, 2] * A[c, 2] + T[r, 3] * A[c, 3]
                     + T[r, 4] * B[c, 0] + T[r, 5] * B[c, 1] + T[r, 6] * B[c, 2])
                P[r, c] = s
                P[c, r] = s
            P[r, r] += qq
            for c in range(4, 7):
                P[r, c] = T[r, c]
                P[c, r] = T[r, c]
        for r in range(4, 7):
            P[r, r] += qw

        # ---- measurement update (eqs. 11-15, 17, 22) -------------------------------------------
        if use_mag:
            _triad_into(acc[k, 0], acc[k, 1], acc[k, 2], mag[k, 0], mag[k, 1], mag[k, 2], 1, z, 0)
        else:
            # predicted north in sensor coordinates: first row of R(q^-), up to scale
            p0, p1, p2, p3 = x[0], x[1], x[2], x[3]
            nx = p0 * p0 + p1 * p1 - p2 * p2 - p3 * p3
            ny = 2.0 * (p1 * p2 - p0 * p3)
            nz = 2.0 * (p1 * p3 + p0 * p2)
            _triad_into(acc[k, 0], acc[k, 1], acc[k, 2], nx, ny, nz, 1, z, 0)
        ok = not math.isnan(z[0, 0])
        if ok and gate < math.inf:
            # acceleration gate: |acc| far from g means the TRIAD's first vector is not gravity
            an = math.sqrt(acc[k, 0] * acc[k, 0] + acc[k, 1] * acc[k, 1] + acc[k, 2] * acc[k, 2])
            ok = abs(an - g_ref) <= gate * g_ref
        dot = z[0, 0] * x[0] + z[0, 1] * x[1] + z[0, 2] * x[2] + z[0, 3] * x[3]
        if ok and dot < 0.0:
            dot = -dot
            for r in range(4):
                z[0, r] = -z[0, r]
        if ok:
            r_k = rho * (kscale[k] if nk > 1 else kscale[0])
            if huber < math.inf:
                # Huber weight: innovation angle d beyond huber -> R scaled by d / huber
                nx = math.sqrt(x[0] * x[0] + x[1] * x[1] + x[2] * x[2] + x[3] * x[3])
                d = 2.0 * math.acos(min(dot / nx, 1.0))
                if d > huber:
                    r_k *= d / huber
            # Cholesky of S = P_qq + R_k (4 x 4, SPD)
            for r in range(4):
                for c in range(r + 1):
                    s = P[r, c]
                    if r == c:
                        s += r_k
                    for m in range(c):
                        s -= L[r, m] * L[c, m]
                    if r == c:
                        L[r, r] = math.sqrt(s)
                    else:
                        L[r, c] = s / L[c, c]
            # W = L^{-1} P[:4, :], v = L^{-1} (z - q^-)
            for r in range(4):
                inv = 1.0 / L[r, r]
                for c in range(7):
                    s = P[r, c]
                    for m in range(r):
                        s -= L[r, m] * W[m, c]
                    W[r, c] = s * inv
                s = z[0, r] - x[r]
                for m in range(r):
                    s -= L[r, m] * v[m]
                v[r] = s * inv
            # x += G (z - q^-) = W^T v;  P -= W^T W
            for c in range(7):
                x[c] += W[0, c] * v[0] + W[1, c] * v[1] + W[2, c] * v[2] + W[3, c] * v[3]
            for r in range(7):
                for c in range(r, 7):
                    s = P[r, c] - (W[0, r] * W[0, c] + W[1, r] * W[1, c]
                                   + W[2, r] * W[2, c] + W[3, r] * W[3, c])
                    P[r, c] = s
                    P[c, r] = s
        nq = math.sqrt(x[0] * x[0] + x[1] * x[1] + x[2] * x[2] + x[3] * x[3])
        inv = 1.0 / nq
        for i in range(4):
            x[i] *= inv
            out_q[k, i] = x[i]
        for i in range(3):
            out_b[k, i] = x[4 + i]
