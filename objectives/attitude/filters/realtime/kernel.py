"""Numba kernel of the ``realtime`` filter (:mod:`objectives.attitude.filters.realtime`).

The design follows VQF (D. Laidig, T. Seel, "VQF: Highly accurate IMU orientation estimation with bias
estimation and magnetic disturbance rejection", Information Fusion 91:187-204, 2023), written for this
project as one pass over whole arrays: strapdown integration of the bias-corrected gyroscope, an
inclination correction from the accelerometer low-passed in the (almost) inertial frame, a heading offset
``delta`` corrected from the magnetometer alone, a Kalman bias estimate in motion and at rest, rest
detection, and magnetic disturbance detection by norm and dip with a rejection time limit.

Layouts (declared once in :mod:`objectives.attitude.filters.realtime.coefficients`; the kernel indexes
``c[C.K_MAG]``):

- ``coef`` (``C.LEN``,): per-sample coefficients derived from the time constants once per run;
- ``state`` (``S.LEN``,): everything carried from one sample to the next (resumable: a run split in
  two with the state passed on equals one run).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from objectives.attitude.filters._scalar import qmul
from objectives.attitude.filters.realtime.coefficients import C, S

__all__ = ["realtime_kernel"]

_EPS = np.finfo(np.float64).eps


@njit
def _lp_start(s, off, n, x, y, c, k, tau, dt):
    """The start phase of the low-pass :func:`_lp` (its state's first entry NaN): the output is the running
    mean of the first ``tau`` s, after which the filter starts in steady state at that mean."""
    b0 = c[k]
    b2 = c[k + 2]
    a2 = c[k + 4]
    if math.isnan(s[off + 1]):
        s[off + 1] = 0.0  # sample count
        for j in range(n):
            s[off + n + j] = 0.0  # running sums
    s[off + 1] += 1.0
    cnt = s[off + 1]
    for j in range(n):
        s[off + n + j] += x[j]
        y[j] = s[off + n + j] / cnt
    if cnt * dt >= tau:
        for j in range(n):
            s[off + j] = y[j] * (1.0 - b0)
            s[off + n + j] = y[j] * (b2 - a2)


@njit(cache=True, inline="always")
def _lp(s, off, n, x, y, c, k):
    """One step of the second-order low-pass of ``n`` channels ``x`` -> ``y`` (state ``s[off:off + 2n]``,
    coefficients ``c[k:k + 5]``); False, doing nothing, during its start phase (the state's first entry NaN),
    where the caller runs :func:`_lp_start` instead (a call kept out of this inlined step: around a call numba
    keeps an atomic reference count of each array argument)."""
    if math.isnan(s[off]):
        return False
    b0 = c[k]
    b1 = c[k + 1]
    b2 = c[k + 2]
    a1 = c[k + 3]
    a2 = c[k + 4]
    for j in range(n):
        yj = b0 * x[j] + s[off + j]
        s[off + j] = b1 * x[j] - a1 * yj + s[off + n + j]
        s[off + n + j] = b2 * x[j] - a2 * yj
        y[j] = yj
    return True


@njit(cache=True, inline="always")
def _dist2(y, v0, v1, v2):
    """The squared distance of ``(v0, v1, v2)`` from ``y[:3]`` (rest detection's deviation from its low-pass)."""
    d0 = v0 - y[0]
    d1 = v1 - y[1]
    d2 = v2 - y[2]
    return d0 * d0 + d1 * d1 + d2 * d2


@njit(cache=True, inline="always")
def _rotate(q0, q1, q2, q3, v0, v1, v2):
    """``q (x) v (x) q*``."""
    x = (1 - 2 * q2 * q2 - 2 * q3 * q3) * v0 + 2 * v1 * (q2 * q1 - q0 * q3) + 2 * v2 * (q0 * q2 + q3 * q1)
    y = 2 * v0 * (q0 * q3 + q2 * q1) + v1 * (1 - 2 * q1 * q1 - 2 * q3 * q3) + 2 * v2 * (q2 * q3 - q1 * q0)
    z = 2 * v0 * (q3 * q1 - q0 * q2) + 2 * v1 * (q0 * q1 + q3 * q2) + v2 * (1 - 2 * q1 * q1 - 2 * q2 * q2)
    return x, y, z


@njit(cache=True, inline="always")
def _normq(s, k):
    n = math.sqrt(s[k] * s[k] + s[k + 1] * s[k + 1] + s[k + 2] * s[k + 2] + s[k + 3] * s[k + 3])
    if n != 0.0:
        for j in range(4):
            s[k + j] /= n


@njit
def _q6(s):
    """The 6-D quaternion ``accQuat (x) gyrQuat``."""
    return qmul(s[S.ACC_Q], s[S.ACC_Q + 1], s[S.ACC_Q + 2], s[S.ACC_Q + 3],
                s[S.GYR_Q], s[S.GYR_Q + 1], s[S.GYR_Q + 2], s[S.GYR_Q + 3])


@njit(cache=True, inline="always")
def _inv3(m, out):
    """``out = inv(m)`` for row-major (9,) ``m`` by cofactors (inlined: with no call in its body, numba keeps no
    reference counts of :func:`_bias_update`'s array arguments)."""
    a, b, c, d, e, f, g, h, k = m[0], m[1], m[2], m[3], m[4], m[5], m[6], m[7], m[8]
    c00 = e * k - f * h
    c01 = f * g - d * k
    c02 = d * h - e * g
    det = a * c00 + b * c01 + c * c02
    out[0] = c00 / det
    out[1] = (c * h - b * k) / det
    out[2] = (b * f - c * e) / det
    out[3] = c01 / det
    out[4] = (a * k - c * g) / det
    out[5] = (c * d - a * f) / det
    out[6] = c02 / det
    out[7] = (b * g - a * h) / det
    out[8] = (a * e - b * d) / det


@njit(cache=True, inline="always")
def _mul3(a, b, bo, out):
    """``out = A B`` of row-major 3x3 matrices ``a[0:9]`` and ``b[bo:bo+9]`` (``out`` is neither)."""
    for i in range(3):
        for j in range(3):
            acc = 0.0
            for m in range(3):
                acc += a[3 * i + m] * b[bo + 3 * m + j]
            out[3 * i + j] = acc


@njit
def _bias_update(s, c, r, e, w, t1, t2, t3):
    """Kalman update of the bias with measurement matrix ``r`` (9,), residual ``e`` (3,) and diagonal
    measurement variance ``w`` (3,): ``K = P R^T (W + R P R^T)^-1``, ``b += K e``, ``P -= K R P``."""
    p = S.BIAS_P
    # t1 = P R^T
    for i in range(3):
        for j in range(3):
            acc = 0.0
            for m in range(3):
                acc += s[p + 3 * i + m] * r[3 * j + m]
            t1[3 * i + j] = acc
    # t2 = W + R (P R^T)
    for i in range(3):
        for j in range(3):
            acc = 0.0
            for m in range(3):
                acc += r[3 * i + m] * t1[3 * m + j]
            t2[3 * i + j] = acc + (w[i] if i == j else 0.0)
    _inv3(t2, t3)
    # K = t1 t3 -> t2
    _mul3(t1, t3, 0, t2)
    for i in range(3):
        s[S.BIAS + i] += t2[3 * i] * e[0] + t2[3 * i + 1] * e[1] + t2[3 * i + 2] * e[2]
    # t3 = K R ; P -= t3 P
    _mul3(t2, r, 0, t3)
    _mul3(t3, s, p, t1)
    for k in range(9):
        s[p + k] -= t1[k]


@njit
def _clip(x, lim):
    return min(max(x, -lim), lim)


@njit(cache=True)
def realtime_kernel(gyr, acc, mag, c, s, out, bias_out, flags_out):
    """The filter over whole arrays (see the module docstring).

    Parameters
    ----------
    gyr, acc, mag : (N, 3) float64
        rad/s, m/s^2, any unit; ``mag`` may be (0, 3) (6-D).
    c : (COEF_LEN,) float64
        :func:`coefficients`.
    s : (STATE_LEN,) float64
        :func:`initial_state`; read and written (the state after the last sample).
    out : (N, 4) float64
        Written: sensor-to-earth quaternion (ENU) after each sample (6-D without magnetometer).
    bias_out : (N, 3) float64
        Written: gyro bias estimate, rad/s.
    flags_out : (N, 3) float64
        Written: rest detected (0/1), magnetic disturbance detected (0/1), heading offset ``delta`` rad.
    """
    dt = c[C.DT]
    use_mag = c[C.USE_MAG] != 0.0 and mag.shape[0] == gyr.shape[0]
    motion_bias = c[C.MOTION_BIAS] != 0.0
    rest_bias = c[C.REST_BIAS] != 0.0
    mag_rej = c[C.MAG_REJ] != 0.0
    # the first field at rest: the rest detector runs on the accelerometer too, with or without the rest bias
    first_at_rest = mag_rej and use_mag and c[C.MAG_FIRST_AT_REST] != 0.0
    clip = c[C.BIAS_CLIP]
    x = np.empty(9)
    y = np.empty(9)
    r = np.empty(9)
    e = np.empty(3)
    w = np.empty(3)
    t1 = np.empty(9)
    t2 = np.empty(9)
    t3 = np.empty(9)
    for i in range(gyr.shape[0]):
        # --- gyroscope: rest detection on the low-passed rate, then strapdown integration
        g0, g1, g2 = gyr[i, 0], gyr[i, 1], gyr[i, 2]
        if rest_bias or mag_rej:
            x[0], x[1], x[2] = g0, g1, g2
            if not _lp(s, S.REST_GYR_LP, 3, x, y, c, C.REST_LP):
                _lp_start(s, S.REST_GYR_LP, 3, x, y, c, C.REST_LP, c[C.REST_TAU], dt)
            if _dist2(y, g0, g1, g2) >= c[C.REST_TH_GYR] ** 2 or max(abs(y[0]), max(abs(y[1]), abs(y[2]))) > clip:
                s[S.REST_T] = 0.0
                s[S.REST] = 0.0
            s[S.REST_GYR] = y[0]
            s[S.REST_GYR + 1] = y[1]
            s[S.REST_GYR + 2] = y[2]
        u0 = g0 - s[S.BIAS]
        u1 = g1 - s[S.BIAS + 1]
        u2 = g2 - s[S.BIAS + 2]
        un = math.sqrt(u0 * u0 + u1 * u1 + u2 * u2)
        if un > _EPS:
            ang = un * dt
            cw = math.cos(ang / 2.0)
            sw = math.sin(ang / 2.0) / un
            q = qmul(s[S.GYR_Q], s[S.GYR_Q + 1], s[S.GYR_Q + 2], s[S.GYR_Q + 3], cw, sw * u0, sw * u1, sw * u2)
            for j in range(4):
                s[S.GYR_Q + j] = q[j]
            _normq(s, S.GYR_Q)
        # --- accelerometer
        a0, a1, a2 = acc[i, 0], acc[i, 1], acc[i, 2]
        if not (a0 == 0.0 and a1 == 0.0 and a2 == 0.0):
            if rest_bias or first_at_rest:
                x[0], x[1], x[2] = a0, a1, a2
                if not _lp(s, S.REST_ACC_LP, 3, x, y, c, C.REST_LP):
                    _lp_start(s, S.REST_ACC_LP, 3, x, y, c, C.REST_LP, c[C.REST_TAU], dt)
                if _dist2(y, a0, a1, a2) >= c[C.REST_TH_ACC] ** 2:
                    s[S.REST_T] = 0.0
                    s[S.REST] = 0.0
                else:
                    s[S.REST_T] += dt
                    if s[S.REST_T] >= c[C.REST_MIN]:
                        s[S.REST] = 1.0
            # low-pass of the accelerometer in the strapdown (almost inertial) frame
            x[0], x[1], x[2] = _rotate(s[S.GYR_Q], s[S.GYR_Q + 1], s[S.GYR_Q + 2], s[S.GYR_Q + 3], a0, a1, a2)
            if not _lp(s, S.ACC_LP, 3, x, y, c, C.ACC_LP):
                _lp_start(s, S.ACC_LP, 3, x, y, c, C.ACC_LP, c[C.TAU_ACC], dt)
            ex, ey, ez = _rotate(s[S.ACC_Q], s[S.ACC_Q + 1], s[S.ACC_Q + 2], s[S.ACC_Q + 3], y[0], y[1], y[2])
            en = math.sqrt(ex * ex + ey * ey + ez * ez)
            if en != 0.0:
                ex /= en
                ey /= en
                ez /= en
            # inclination correction: the smallest rotation taking the filtered acc to the vertical
            qw = math.sqrt((ez + 1.0) / 2.0)
            if qw > 1e-6:
                q = qmul(qw, 0.5 * ey / qw, -0.5 * ex / qw, 0.0,
                         s[S.ACC_Q], s[S.ACC_Q + 1], s[S.ACC_Q + 2], s[S.ACC_Q + 3])
            else:
                q = qmul(0.0, 1.0, 0.0, 0.0, s[S.ACC_Q], s[S.ACC_Q + 1], s[S.ACC_Q + 2], s[S.ACC_Q + 3])
            for j in range(4):
                s[S.ACC_Q + j] = q[j]
            _normq(s, S.ACC_Q)
            # --- gyro bias: Kalman filter, at rest on the low-passed rate, in motion on the inclination error
            if motion_bias or rest_bias:
                b0_, b1_, b2_ = s[S.BIAS], s[S.BIAS + 1], s[S.BIAS + 2]
                p0, p1, p2, p3 = _q6(s)
                r[0] = 1 - 2 * p2 * p2 - 2 * p3 * p3
                r[1] = 2 * (p2 * p1 - p0 * p3)
                r[2] = 2 * (p0 * p2 + p3 * p1)
                r[3] = 2 * (p0 * p3 + p2 * p1)
                r[4] = 1 - 2 * p1 * p1 - 2 * p3 * p3
                r[5] = 2 * (p2 * p3 - p1 * p0)
                r[6] = 2 * (p3 * p1 - p0 * p2)
                r[7] = 2 * (p0 * p1 + p3 * p2)
                r[8] = 1 - 2 * p1 * p1 - 2 * p2 * p2
                x[0] = r[0] * b0_ + r[1] * b1_ + r[2] * b2_
                x[1] = r[3] * b0_ + r[4] * b1_ + r[5] * b2_
                for j in range(9):
                    y[j] = r[j]
                if not _lp(s, S.R_LP, 9, y, r, c, C.ACC_LP):
                    _lp_start(s, S.R_LP, 9, y, r, c, C.ACC_LP, c[C.TAU_ACC], dt)
                if not _lp(s, S.BLP, 2, x, y, c, C.ACC_LP):
                    _lp_start(s, S.BLP, 2, x, y, c, C.ACC_LP, c[C.TAU_ACC], dt)
                has_meas = True
                if s[S.REST] != 0.0 and rest_bias:
                    for j in range(3):
                        e[j] = s[S.REST_GYR + j] - s[S.BIAS + j]
                        w[j] = c[C.BIAS_REST_W]
                    for j in range(9):
                        r[j] = 1.0 if j % 4 == 0 else 0.0
                elif motion_bias:
                    e[0] = -ey / dt + y[0] - r[0] * b0_ - r[1] * b1_ - r[2] * b2_
                    e[1] = ex / dt + y[1] - r[3] * b0_ - r[4] * b1_ - r[5] * b2_
                    e[2] = -r[6] * b0_ - r[7] * b1_ - r[8] * b2_
                    w[0] = c[C.BIAS_MOTION_W]
                    w[1] = c[C.BIAS_MOTION_W]
                    w[2] = c[C.BIAS_VERT_W]
                else:
                    has_meas = False
                for j in range(3):
                    if s[S.BIAS_P + 4 * j] < c[C.BIAS_P0]:
                        s[S.BIAS_P + 4 * j] += c[C.BIAS_V]
                if has_meas:
                    for j in range(3):
                        e[j] = _clip(e[j], clip)
                    _bias_update(s, c, r, e, w, t1, t2, t3)
                    for j in range(3):
                        s[S.BIAS + j] = _clip(s[S.BIAS + j], clip)
        # --- magnetometer: heading offset delta only
        if use_mag:
            m0, m1, m2 = mag[i, 0], mag[i, 1], mag[i, 2]
            if not (m0 == 0.0 and m1 == 0.0 and m2 == 0.0):
                p0, p1, p2, p3 = _q6(s)
                h0, h1, h2 = _rotate(p0, p1, p2, p3, m0, m1, m2)
                if mag_rej:
                    nrm = math.sqrt(h0 * h0 + h1 * h1 + h2 * h2)
                    x[0] = nrm
                    x[1] = -math.asin(h2 / nrm)
                    if c[C.MAG_TAU] > 0.0:
                        if not _lp(s, S.MAG_LP, 2, x, y, c, C.MAG_LP):
                            _lp_start(s, S.MAG_LP, 2, x, y, c, C.MAG_LP, c[C.MAG_TAU], dt)
                    else:
                        y[0] = x[0]
                        y[1] = x[1]
                    nd, dip = y[0], y[1]
                    kref = c[C.K_MAG_REF]
                    ref_n = s[S.MAG_REF_NORM]
                    if abs(nd - ref_n) < c[C.MAG_NORM_TH] * ref_n and abs(dip - s[S.MAG_REF_DIP]) < c[C.MAG_DIP_TH]:
                        s[S.MAG_UNDIST_T] += dt
                        if s[S.MAG_UNDIST_T] >= c[C.MAG_MIN_UNDIST]:
                            s[S.MAG_DIST] = 0.0
                            s[S.MAG_REF_NORM] += kref * (nd - s[S.MAG_REF_NORM])
                            s[S.MAG_REF_DIP] += kref * (dip - s[S.MAG_REF_DIP])
                    else:
                        s[S.MAG_UNDIST_T] = 0.0
                        s[S.MAG_DIST] = 1.0
                    # a new homogeneous field is accepted after mag_new_s of rotation in it; the first one also
                    # after mag_new_first_s at rest (mag_first_at_rest)
                    cn = s[S.MAG_CAND_NORM]
                    if abs(nd - cn) < c[C.MAG_NORM_TH] * cn and abs(dip - s[S.MAG_CAND_DIP]) < c[C.MAG_DIP_TH]:
                        gl = math.sqrt(s[S.REST_GYR] ** 2 + s[S.REST_GYR + 1] ** 2 + s[S.REST_GYR + 2] ** 2)
                        if gl >= c[C.MAG_NEW_MIN_GYR] or (first_at_rest and ref_n == 0.0 and s[S.REST] != 0.0):
                            s[S.MAG_CAND_T] += dt
                        s[S.MAG_CAND_NORM] += kref * (nd - s[S.MAG_CAND_NORM])
                        s[S.MAG_CAND_DIP] += kref * (dip - s[S.MAG_CAND_DIP])
                        if s[S.MAG_DIST] != 0.0 and (s[S.MAG_CAND_T] >= c[C.MAG_NEW] or (
                                s[S.MAG_REF_NORM] == 0.0 and s[S.MAG_CAND_T] >= c[C.MAG_NEW_FIRST])):
                            s[S.MAG_REF_NORM] = s[S.MAG_CAND_NORM]
                            s[S.MAG_REF_DIP] = s[S.MAG_CAND_DIP]
                            s[S.MAG_DIST] = 0.0
                            s[S.MAG_UNDIST_T] = c[C.MAG_MIN_UNDIST]
                    else:
                        s[S.MAG_CAND_T] = 0.0
                        s[S.MAG_CAND_NORM] = nd
                        s[S.MAG_CAND_DIP] = dip
                dis = math.atan2(h0, h1) - s[S.DELTA]
                if dis > math.pi:
                    dis -= 2.0 * math.pi
                elif dis < -math.pi:
                    dis += 2.0 * math.pi
                k = c[C.K_MAG]
                if mag_rej:
                    if s[S.MAG_DIST] != 0.0:
                        if s[S.MAG_REJECT_T] <= c[C.MAG_MAX_REJ]:
                            s[S.MAG_REJECT_T] += dt
                            k = 0.0
                        else:
                            k /= c[C.MAG_REJ_FACTOR]
                    else:
                        if s[S.MAG_REJECT_T] > 0.0 and c[C.K_MAG_REC] > k:
                            # fast re-convergence while the rejection budget recovers
                            k = c[C.K_MAG_REC]
                        s[S.MAG_REJECT_T] = max(s[S.MAG_REJECT_T] - c[C.MAG_REJ_FACTOR] * dt, 0.0)
                kin = s[S.K_MAG_INIT]
                if kin != 0.0:
                    # fast start: gain at least 1/n over the first samples, until t > tau_mag_s
                    if k < kin:
                        k = kin
                    kin = kin / (kin + 1.0)
                    if kin * c[C.TAU_MAG] < dt:
                        kin = 0.0
                    s[S.K_MAG_INIT] = kin
                d = s[S.DELTA] + k * dis
                if d > math.pi:
                    d -= 2.0 * math.pi
                elif d < -math.pi:
                    d += 2.0 * math.pi
                s[S.DELTA] = d
        # --- output
        p0, p1, p2, p3 = _q6(s)
        if use_mag:
            cd = math.cos(s[S.DELTA] / 2.0)
            sd = math.sin(s[S.DELTA] / 2.0)
            p0, p1, p2, p3 = cd * p0 - sd * p3, cd * p1 - sd * p2, cd * p2 + sd * p1, cd * p3 + sd * p0
        out[i, 0] = p0
        out[i, 1] = p1
        out[i, 2] = p2
        out[i, 3] = p3
        bias_out[i, 0] = s[S.BIAS]
        bias_out[i, 1] = s[S.BIAS + 1]
        bias_out[i, 2] = s[S.BIAS + 2]
        flags_out[i, 0] = s[S.REST]
        flags_out[i, 1] = s[S.MAG_DIST]
        flags_out[i, 2] = s[S.DELTA]
