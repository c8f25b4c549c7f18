"""Numba kernel of the quaternion EKF / FAEKF (FAEKF paper eqs. 16-22, 36, 31).

The filter classes, parameter declarations and the fuzzy scaling live in
:mod:`objectives.attitude.filters.ekf`; see its docstring for the equations and deviations. The coefficient
array's layout is :data:`C`, the state's :data:`X` (declared once; the C port's enums and sizes come from them).

Both public kernels run one loop, :func:`_steps`: the paper's filter with the robust blocks behind
flags (all off for :func:`ekf_kernel` and :func:`ekf_steps`, which then compute bit for bit what the
paper's filter computes). Its parts that are not the measurement update are inner functions that
numba inlines (:func:`_predict`, :func:`_emit`, the robust blocks' helpers); the measurement update
stays written out in the loop, where it compiles to the fastest code.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from objectives.attitude.filters.layout import Layout
from objectives.attitude.filters.robust import _mag_dist_update, _rest_update, acc_lp_step
from objectives.attitude.quaternion import _triad_into
from objectives.jit import uncached

__all__ = ["ekf_kernel", "ekf_steps", "ekf_robust_kernel", "C", "X", "N_COEF"]

#: the coefficient array (the first 8 entries are required, the options after them may be left out: off)
C = Layout("C", (("DT", 1, "sample time, s"),
                 ("QQ", 1, "q_q, quaternion process noise per sample (eq. 36)"),
                 ("QW", 1, "q_w, gyro bias random walk per sample, (rad/s)^2 (eq. 36)"),
                 ("RHO", 1, "rho, TRIAD measurement variance (eq. 36)"),
                 ("P0Q", 1, "initial quaternion variance (eq. 18)"),
                 ("P0B", 1, "initial bias variance, (rad/s)^2 (eq. 18)"),
                 ("USE_MAG", 1, "1: TRIAD with the magnetometer, 0: north predicted"),
                 ("EXACT", 1, "1: exponential quaternion step, 0: the first-order step of eq. 16"),
                 ("GATE", 1, "acc_gate, relative to g (inf: off)"),
                 ("G", 1, "gravity in the accelerometer's unit"),
                 ("HUBER", 1, "Huber innovation angle, rad (inf: off)"),
                 ("CUR", 1, "1: gyro sample k propagates k-1 -> k; 0: sample k-1")))
#: the length of a complete coefficient array
N_COEF = C.LEN
#: the state: the sensor-to-earth quaternion (NED) and the gyro bias
X = Layout("X", (("Q", 4, "sensor-to-earth quaternion, NED"), ("BIAS", 3, "gyro bias, rad/s")))


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
    coef : (8,) to (C.LEN,) float64
        Layout :data:`C`: ``dt`` (s), ``q_q``, ``q_w``, ``rho``, ``p0_q``, ``p0_b`` (initial variances),
        ``use_mag``, ``exact`` (1: exponential quaternion step, 0: the first-order step of eq. 16); optional:
        ``acc_gate`` (relative, inf: off), ``g`` (gravity in acc units), ``huber`` (rad, inf: off),
        ``current`` (1: gyro sample ``k`` propagates ``k-1 -> k``; 0: sample ``k-1``).
    kscale : (N,) or (1,) float64
        Per-sample scale ``K_k`` of ``R`` (FAEKF), or a single constant (1.0 for the EKF).
    x0 : (X.LEN,) float64
        Initial state (layout :data:`X`): NED sensor-to-earth quaternion and gyro bias (rad/s).
    out_q : (N, 4) float64, out
        Normalised quaternion estimates, NED sensor-to-earth.
    out_b : (N, 3) float64, out
        Gyro bias estimates, rad/s.
    """
    x = np.empty(X.LEN)
    P = np.zeros((X.LEN, X.LEN))
    _start(coef, x0, x, P, out_q, out_b)
    ekf_steps_inner(gyr, acc, mag, coef, kscale, x, P, 1, out_q, out_b)


#: the uncached twin other kernels call (objectives.jit)
ekf_kernel_inner = uncached(ekf_kernel)


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
    off = np.zeros(4)  # flags all 0; the blocks' coefficients are then never read
    _steps(gyr, acc, mag, coef, kscale, off, off, off, off, x, P, k_start, out_q, out_b, np.empty((0, 2)))


#: the uncached twin other kernels call (objectives.jit)
ekf_steps_inner = uncached(ekf_steps)


@njit(cache=True)
def ekf_robust_kernel(gyr, acc, mag, coef, kscale, flags, mcoef, rcoef, acoef, x0, out_q, out_b, out_d):
    """:func:`ekf_kernel` with the robust blocks of :mod:`objectives.attitude.filters.robust`.

    With every flag 0 it computes what :func:`ekf_kernel` computes (the EKF calls that kernel then).

    - ``flags[2]`` (acc low-pass, ``tau_acc_s > 0``): the TRIAD's first vector is the accelerometer
      low-passed in the earth frame of the predicted attitude (block c), not the raw sample.
    - ``flags[0]`` (magnetic rejection): the magnetometer in the earth frame feeds block (a) (field norm
      and dip angle against a reference learned when undisturbed, full rejection for at most
      ``mcoef``'s time limit); its gain ``g`` blends the TRIAD's second vector between the measured
      horizontal field (``g = 1``) and the predicted north (``g = 0``: heading from the gyro). Until a
      first reference is accepted the magnetometer is used fully.
    - ``flags[1]`` (rest bias): block (b) detects rest; at rest the low-passed gyro is a measurement of
      the bias state (three scalar Kalman updates of variance ``flags[3]``, (rad/s)^2).

    Parameters
    ----------
    gyr, acc, mag, coef, kscale, x0, out_q, out_b
        As :func:`ekf_kernel` (``coef`` with all 12 entries).
    flags : (4,) float64
        ``mag_rejection``, ``rest_bias``, ``acc_lp`` (1/0) and ``r_rest``.
    mcoef, rcoef, acoef : float64 arrays
        Coefficients of blocks (a), (b), (c) (``mag_dist_coefficients``, ``rest_coefficients``,
        ``acc_lp_coefficients``).
    out_d : (N, 2) float64, out
        Magnetometer gain (1: used fully) and rest flag per sample.
    """
    x = np.empty(X.LEN)
    P = np.zeros((X.LEN, X.LEN))
    _start(coef, x0, x, P, out_q, out_b)
    out_d[0, 0] = 1.0
    out_d[0, 1] = 0.0
    _steps(gyr, acc, mag, coef, kscale, flags, mcoef, rcoef, acoef, x, P, 1, out_q, out_b, out_d)


@njit
def _steps(gyr, acc, mag, coef, kscale, flags, mcoef, rcoef, acoef, x, P, k_start, out_q, out_b, out_d):
    """Samples ``k_start .. N-1`` from the state ``(x, P)``: :func:`ekf_steps` (all flags 0, ``out_d``
    empty) or :func:`ekf_robust_kernel` (blocks as ``flags`` say; their states start here).

    Arguments as in :func:`ekf_robust_kernel` and :func:`ekf_steps`; an empty ``out_d`` is not written.
    """
    h, qq, qw, rho, use_mag, exact, gate, g_ref, huber, cur = _options(coef)
    use_rej, use_rest, use_alp, r_rest = flags[0] != 0.0, flags[1] != 0.0, flags[2] != 0.0, flags[3]
    with_d = out_d.shape[0] > 0
    nk = kscale.shape[0]
    ms = _mag_dist_state()
    rs = np.zeros(12)
    ast = np.zeros(4)
    A = np.empty((4, 4))
    B = np.empty((4, 3))
    T = np.empty((4, 7))
    W = np.empty((4, 7))
    L = np.zeros((4, 4))
    z = np.empty((1, 4))
    v = np.empty(4)
    for k in range(k_start, gyr.shape[0]):
        at_rest = False
        if use_rest or use_rej:
            at_rest = _rest_update(rs, rcoef, gyr[k, 0], gyr[k, 1], gyr[k, 2], acc[k, 0], acc[k, 1], acc[k, 2])
        _predict(gyr, k - 1 + cur, h, qq, qw, exact, x, P, A, B, T)

        # ---- TRIAD measurement (eqs. 11-15), from the robust blocks' vectors where they are on ------
        if use_alp:
            ast[0], ast[1], ast[2], ast[3], ax, ay, az = acc_lp_step(
                acoef[0], ast[0], ast[1], ast[2], ast[3], x[0], x[1], x[2], x[3], acc[k, 0], acc[k, 1], acc[k, 2])
        else:
            ax, ay, az = acc[k, 0], acc[k, 1], acc[k, 2]
        gm = 1.0
        if use_mag:
            mx, my, mz = mag[k, 0], mag[k, 1], mag[k, 2]
            if use_rej:
                nx, ny, nz = _north(x)
                gm = _mag_gain(ms, mcoef, rs, x, nx, ny, nz, mx, my, mz)
                if gm < 1.0:
                    mx, my, mz = _blend_north(ax, ay, az, gm, nx, ny, nz, mx, my, mz)
            _triad_into(ax, ay, az, mx, my, mz, 1, z, 0)
        else:
            nx, ny, nz = _north(x)
            _triad_into(ax, ay, az, nx, ny, nz, 1, z, 0)
        if with_d:
            out_d[k, 0] = gm
            out_d[k, 1] = 1.0 if at_rest else 0.0

        # ---- measurement update (eqs. 17, 22; R_k = rho K_k of eq. 31) -------------------------------
        ok = not math.isnan(z[0, 0])
        if ok and gate < math.inf:
            # acceleration gate: |acc| far from g means the TRIAD's first vector is not gravity
            an = math.sqrt(acc[k, 0] * acc[k, 0] + acc[k, 1] * acc[k, 1] + acc[k, 2] * acc[k, 2])
            ok = abs(an - g_ref) <= gate * g_ref
        if ok:
            dot = z[0, 0] * x[0] + z[0, 1] * x[1] + z[0, 2] * x[2] + z[0, 3] * x[3]
            if dot < 0.0:
                dot = -dot
                for r in range(4):
                    z[0, r] = -z[0, r]
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
        if use_rest and at_rest:
            _rest_bias_update(rs, r_rest, x, P, W)
        _emit(x, k, out_q, out_b)


# ---------------------------------------------------------------------------------------------
# inner steps (inlined into the loop)
# ---------------------------------------------------------------------------------------------
@njit(cache=True, inline="always")
def _options(coef):
    """The coefficients as scalars: ``h = dt/2``, ``q_q``, ``q_w``, ``rho``, ``use_mag``, ``exact``,
    ``acc_gate``, ``g``, ``huber`` (the optional ones off when ``coef`` is short) and ``current``."""
    gate = coef[C.GATE] if coef.shape[0] > C.GATE else math.inf
    g_ref = coef[C.G] if coef.shape[0] > C.G else 1.0
    huber = coef[C.HUBER] if coef.shape[0] > C.HUBER else math.inf
    cur = 1 if (coef.shape[0] > C.CUR and coef[C.CUR] != 0.0) else 0
    return (0.5 * coef[C.DT], coef[C.QQ], coef[C.QW], coef[C.RHO], coef[C.USE_MAG] != 0.0, coef[C.EXACT] != 0.0,
            gate, g_ref, huber, cur)


@njit(cache=True, inline="always")
def _start(coef, x0, x, P, out_q, out_b):
    """Initial state (eq. 18): ``x`` = ``x0`` with its quaternion normalised, ``P = diag(p0_q I4, p0_b I3)``
    (``P`` zero on entry); written as sample 0 of the outputs."""
    for i in range(4):
        P[i, i] = coef[C.P0Q]
    for i in range(4, 7):
        P[i, i] = coef[C.P0B]
    for i in range(7):
        x[i] = x0[i]
    nq = math.sqrt(x[0] * x[0] + x[1] * x[1] + x[2] * x[2] + x[3] * x[3])
    for i in range(4):
        x[i] /= nq
        out_q[0, i] = x[i]
    for i in range(3):
        out_b[0, i] = x[4 + i]


@njit(cache=True, inline="always")
def _predict(gyr, kg, h, qq, qw, exact, x, P, A, B, T):
    """Time update (eqs. 16, 20, 21) of ``(x, P)`` with gyro sample ``kg``; ``A``, ``B``, ``T`` are scratch."""
    q0, q1, q2, q3 = x[0], x[1], x[2], x[3]
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
    A[0, 0], A[0, 1], A[0, 2], A[0, 3] = ca, -hx, -hy, -hz
    A[1, 0], A[1, 1], A[1, 2], A[1, 3] = hx, ca, hz, -hy
    A[2, 0], A[2, 1], A[2, 2], A[2, 3] = hy, -hz, ca, hx
    A[3, 0], A[3, 1], A[3, 2], A[3, 3] = hz, hy, -hx, ca
    # B = d q_k / d b = -h * Xi(q), q (x) (0, w) = Xi(q) w
    B[0, 0], B[0, 1], B[0, 2] = h * q1, h * q2, h * q3
    B[1, 0], B[1, 1], B[1, 2] = -h * q0, h * q3, -h * q2
    B[2, 0], B[2, 1], B[2, 2] = -h * q3, -h * q0, h * q1
    B[3, 0], B[3, 1], B[3, 2] = h * q2, -h * q1, -h * q0
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


@njit(cache=True, inline="always")
def _north(x):
    """Predicted north in sensor coordinates: the first row of ``R(q)`` (eq. 3), up to scale."""
    p0, p1, p2, p3 = x[0], x[1], x[2], x[3]
    return p0 * p0 + p1 * p1 - p2 * p2 - p3 * p3, 2.0 * (p1 * p2 - p0 * p3), 2.0 * (p1 * p3 + p0 * p2)


@njit(cache=True, inline="always")
def _emit(x, k, out_q, out_b):
    """Normalise the quaternion of ``x`` and write the state as sample ``k`` of the outputs."""
    nq = math.sqrt(x[0] * x[0] + x[1] * x[1] + x[2] * x[2] + x[3] * x[3])
    inv = 1.0 / nq
    for i in range(4):
        x[i] *= inv
        out_q[k, i] = x[i]
    for i in range(3):
        out_b[k, i] = x[4 + i]


@njit(cache=True, inline="always")
def _mag_gain(ms, mcoef, rs, x, nx, ny, nz, mx, my, mz):
    """Block (a)'s magnetometer gain for the field ``m`` (sensor frame) at the predicted attitude ``x``;
    1 until block (a) has accepted a first reference."""
    p0, p1, p2, p3 = x[0], x[1], x[2], x[3]
    # magnetometer in the NED earth frame: rows of R(q^-) dotted with m
    ex = nx * mx + ny * my + nz * mz
    ey = 2.0 * (p1 * p2 + p0 * p3) * mx + (p0 * p0 - p1 * p1 + p2 * p2 - p3 * p3) * my \
        + 2.0 * (p2 * p3 - p0 * p1) * mz
    ez = 2.0 * (p1 * p3 - p0 * p2) * mx + 2.0 * (p2 * p3 + p0 * p1) * my \
        + (p0 * p0 - p1 * p1 - p2 * p2 + p3 * p3) * mz
    gl = math.sqrt(rs[0] * rs[0] + rs[1] * rs[1] + rs[2] * rs[2])
    gm = _mag_dist_update(ms, mcoef, ex, ey, -ez, gl)  # block expects z up
    return 1.0 if ms[0] == 0.0 else gm


@njit(cache=True, inline="always")
def _blend_north(ax, ay, az, gm, nx, ny, nz, mx, my, mz):
    """The TRIAD's second vector for magnetometer gain ``gm < 1``: the horizontal (perpendicular to
    ``a``) unit directions of the field (weight ``gm``) and the predicted north (``1 - gm``)."""
    an = math.sqrt(ax ** 2 + ay ** 2 + az ** 2)
    ux, uy, uz = ax / an, ay / an, az / an
    dm = mx * ux + my * uy + mz * uz
    hx_, hy_, hz_ = mx - dm * ux, my - dm * uy, mz - dm * uz
    hn = math.sqrt(hx_ * hx_ + hy_ * hy_ + hz_ * hz_)
    dn = nx * ux + ny * uy + nz * uz
    gx_, gy_, gz_ = nx - dn * ux, ny - dn * uy, nz - dn * uz
    gn = math.sqrt(gx_ * gx_ + gy_ * gy_ + gz_ * gz_)
    if hn > 0.0 and gn > 0.0:
        return (gm * hx_ / hn + (1.0 - gm) * gx_ / gn, gm * hy_ / hn + (1.0 - gm) * gy_ / gn,
                gm * hz_ / hn + (1.0 - gm) * gz_ / gn)
    return mx, my, mz


@njit(cache=True, inline="always")
def _rest_bias_update(rs, r_rest, x, P, W):
    """Bias pseudo-measurement at rest: gyro low-pass ``rs[:3]`` = b, three scalar updates
    (``H = e_{4+i}``, variance ``r_rest``); ``W[0]`` is scratch."""
    for i in range(3):
        j = 4 + i
        s = P[j, j] + r_rest
        innov = rs[i] - x[j]
        for c in range(7):
            W[0, c] = P[c, j] / s
        for c in range(7):
            x[c] += W[0, c] * innov
        for r in range(7):
            for c in range(7):
                P[r, c] -= W[0, r] * W[0, c] * s


@njit
def _mag_dist_state():
    """Initial state of block (a) (as ``robust.mag_dist_state``), allocated inside the kernel."""
    s = np.zeros(11)
    s[3] = -1.0
    s[6] = 1.0
    return s
