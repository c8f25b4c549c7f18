"""PROTOTYPE: the quaternion EKF of :mod:`objectives.attitude.filters.ekf` with the robust blocks of
:mod:`objectives.attitude.filters.robust`, to measure how much they change its cross-validated error on
BROAD before they are wired into the real kernel. Not registered as a filter; the CV tools load it by
``"objectives.attitude.filters._ekf_robust_proto:EKFRobustProto"``.

Changes to :func:`~objectives.attitude.filters.ekf.ekf_kernel` (everything else is a copy of it):

- ``tau_acc_s > 0``: the TRIAD's first vector is the accelerometer low-passed in the earth frame of
  the predicted attitude (robust block (c)), not the raw sample, so fast translations average out.
- ``mag_rejection``: the magnetometer rotated into the earth frame feeds robust block (a); its gain
  factor ``g`` blends the TRIAD's second vector between the measured horizontal field direction
  (``g = 1``) and the predicted north direction (``g = 0``: heading from the gyro). Until a first
  reference field is accepted the magnetometer is used fully (the start is assumed undisturbed, as
  VQF's fast initial heading convergence does).
- ``rest_bias``: robust block (b) detects rest; at rest the low-passed gyro is a measurement of the
  bias state (three scalar Kalman updates with variance ``r_rest``).
"""

from __future__ import annotations

import math
from typing import Any, ClassVar

import numpy as np
from numba import njit

from objectives.attitude.data.recording import Recording
from objectives.attitude.filters.base import FilterResult
from objectives.attitude.filters.ekf import _EKF_DEFAULTS, _EKF_PARAMS, EKF, gravity_in_units
from objectives.attitude.filters.robust import (
    _acc_lp_update,
    _mag_dist_update,
    _rest_update,
    acc_lp_coefficients,
    mag_dist_coefficients,
    rest_coefficients,
)
from objectives.attitude.quaternion import _triad_into
from tuner.space import Real

__all__ = ["EKFRobustProto"]

_C_DT, _C_QQ, _C_QW, _C_RHO, _C_P0Q, _C_P0B, _C_MAG, _C_EXACT, _C_GATE, _C_G, _C_HUBER, _C_CUR = range(12)


@njit(cache=True)
def _kernel(gyr, acc, mag, coef, flags, mcoef, rcoef, acoef, x0, out_q, out_b, out_d):
    """As ``ekf_kernel`` plus flags = (mag_rejection, rest_bias, acc_lp, r_rest); out_d (N, 2): mag gain, rest."""
    n = gyr.shape[0]
    h = 0.5 * coef[_C_DT]
    qq, qw, rho = coef[_C_QQ], coef[_C_QW], coef[_C_RHO]
    use_mag = coef[_C_MAG] != 0.0
    exact = coef[_C_EXACT] != 0.0
    gate, g_ref, huber = coef[_C_GATE], coef[_C_G], coef[_C_HUBER]
    cur = 1 if coef[_C_CUR] != 0.0 else 0
    use_rej, use_rest, use_alp, r_rest = flags[0] != 0.0, flags[1] != 0.0, flags[2] != 0.0, flags[3]
    ms = mag_dist_state_nb()
    rs = np.zeros(12)
    ast = np.zeros(4)
    a_used = np.empty(3)
    P = np.zeros((7, 7))
    for i in range(4):
        P[i, i] = coef[_C_P0Q]
    for i in range(4, 7):
        P[i, i] = coef[_C_P0B]
    A = np.empty((4, 4))
    B = np.empty((4, 3))
    T = np.empty((4, 7))
    W = np.empty((4, 7))
    L = np.zeros((4, 4))
    x = np.empty(7)
    z = np.empty((1, 4))
    v = np.empty(4)
    for i in range(7):
        x[i] = x0[i]
    nq = math.sqrt(x[0] * x[0] + x[1] * x[1] + x[2] * x[2] + x[3] * x[3])
    for i in range(4):
        x[i] /= nq
        out_q[0, i] = x[i]
    for i in range(3):
        out_b[0, i] = x[4 + i]
    out_d[0, 0] = 1.0
    out_d[0, 1] = 0.0
    for k in range(1, n):
        at_rest = False
        if use_rest or use_rej:
            at_rest = _rest_update(rs, rcoef, gyr[k, 0], gyr[k, 1], gyr[k, 2], acc[k, 0], acc[k, 1], acc[k, 2])
        q0, q1, q2, q3 = x[0], x[1], x[2], x[3]
        kg = k - 1 + cur
        wx, wy, wz = gyr[kg, 0] - x[4], gyr[kg, 1] - x[5], gyr[kg, 2] - x[6]
        if exact:
            wn = math.sqrt(wx * wx + wy * wy + wz * wz)
            ang = h * wn
            ca = math.cos(ang)
            sa = h * (math.sin(ang) / ang if ang > 1e-6 else 1.0 - ang * ang / 6.0)
        else:
            ca, sa = 1.0, h
        hx, hy, hz = sa * wx, sa * wy, sa * wz
        A[0, 0], A[0, 1], A[0, 2], A[0, 3] = ca, -hx, -hy, -hz
        A[1, 0], A[1, 1], A[1, 2], A[1, 3] = hx, ca, hz, -hy
        A[2, 0], A[2, 1], A[2, 2], A[2, 3] = hy, -hz, ca, hx
        A[3, 0], A[3, 1], A[3, 2], A[3, 3] = hz, hy, -hx, ca
        B[0, 0], B[0, 1], B[0, 2] = h * q1, h * q2, h * q3
        B[1, 0], B[1, 1], B[1, 2] = -h * q0, h * q3, -h * q2
        B[2, 0], B[2, 1], B[2, 2] = -h * q3, -h * q0, h * q1
        B[3, 0], B[3, 1], B[3, 2] = h * q2, -h * q1, -h * q0
        x[0] = ca * q0 - hx * q1 - hy * q2 - hz * q3
        x[1] = ca * q1 + hx * q0 + hz * q2 - hy * q3
        x[2] = ca * q2 + hy * q0 - hz * q1 + hx * q3
        x[3] = ca * q3 + hz * q0 + hy * q1 - hx * q2
        for r in range(4):
            for c in range(7):
                T[r, c] = (A[r, 0] * P[0, c] + A[r, 1] * P[1, c] + A[r, 2] * P[2, c] + A[r, 3] * P[3, c]
                           + B[r, 0] * P[4, c] + B[r, 1] * P[5, c] + B[r, 2] * P[6, c])
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

        # ---- robust measurement vectors ----------------------------------------------------------
        if use_alp:
            _acc_lp_update(ast, acoef, x, acc[k, 0], acc[k, 1], acc[k, 2], a_used)
        else:
            a_used[0], a_used[1], a_used[2] = acc[k, 0], acc[k, 1], acc[k, 2]
        p0, p1, p2, p3 = x[0], x[1], x[2], x[3]
        # predicted north in sensor coordinates (first row of R(q^-))
        nx = p0 * p0 + p1 * p1 - p2 * p2 - p3 * p3
        ny = 2.0 * (p1 * p2 - p0 * p3)
        nz = 2.0 * (p1 * p3 + p0 * p2)
        gm = 1.0
        if use_mag:
            mx, my, mz = mag[k, 0], mag[k, 1], mag[k, 2]
            if use_rej:
                # magnetometer in the NED earth frame: rows of R(q^-) dotted with m
                ex = nx * mx + ny * my + nz * mz
                ey = 2.0 * (p1 * p2 + p0 * p3) * mx + (p0 * p0 - p1 * p1 + p2 * p2 - p3 * p3) * my \
                    + 2.0 * (p2 * p3 - p0 * p1) * mz
                ez = 2.0 * (p1 * p3 - p0 * p2) * mx + 2.0 * (p2 * p3 + p0 * p1) * my \
                    + (p0 * p0 - p1 * p1 - p2 * p2 + p3 * p3) * mz
                gl = math.sqrt(rs[0] * rs[0] + rs[1] * rs[1] + rs[2] * rs[2])
                gm = _mag_dist_update(ms, mcoef, ex, ey, -ez, gl)  # block expects z up
                if ms[0] == 0.0:
                    gm = 1.0
            if gm < 1.0:
                # blend the horizontal (perpendicular to acc) unit directions of field and predicted north
                an = math.sqrt(a_used[0] ** 2 + a_used[1] ** 2 + a_used[2] ** 2)
                ux, uy, uz = a_used[0] / an, a_used[1] / an, a_used[2] / an
                dm = mx * ux + my * uy + mz * uz
                hx_, hy_, hz_ = mx - dm * ux, my - dm * uy, mz - dm * uz
                hn = math.sqrt(hx_ * hx_ + hy_ * hy_ + hz_ * hz_)
                dn = nx * ux + ny * uy + nz * uz
                gx_, gy_, gz_ = nx - dn * ux, ny - dn * uy, nz - dn * uz
                gn = math.sqrt(gx_ * gx_ + gy_ * gy_ + gz_ * gz_)
                if hn > 0.0 and gn > 0.0:
                    mx = gm * hx_ / hn + (1.0 - gm) * gx_ / gn
                    my = gm * hy_ / hn + (1.0 - gm) * gy_ / gn
                    mz = gm * hz_ / hn + (1.0 - gm) * gz_ / gn
            _triad_into(a_used[0], a_used[1], a_used[2], mx, my, mz, 1, z, 0)
        else:
            _triad_into(a_used[0], a_used[1], a_used[2], nx, ny, nz, 1, z, 0)
        out_d[k, 0] = gm
        out_d[k, 1] = 1.0 if at_rest else 0.0
        ok = not math.isnan(z[0, 0])
        if ok and gate < math.inf:
            an = math.sqrt(acc[k, 0] * acc[k, 0] + acc[k, 1] * acc[k, 1] + acc[k, 2] * acc[k, 2])
            ok = abs(an - g_ref) <= gate * g_ref
        dot = z[0, 0] * x[0] + z[0, 1] * x[1] + z[0, 2] * x[2] + z[0, 3] * x[3]
        if ok and dot < 0.0:
            dot = -dot
            for r in range(4):
                z[0, r] = -z[0, r]
        if ok:
            r_k = rho
            if huber < math.inf:
                nxx = math.sqrt(x[0] * x[0] + x[1] * x[1] + x[2] * x[2] + x[3] * x[3])
                d = 2.0 * math.acos(min(dot / nxx, 1.0))
                if d > huber:
                    r_k *= d / huber
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
            for c in range(7):
                x[c] += W[0, c] * v[0] + W[1, c] * v[1] + W[2, c] * v[2] + W[3, c] * v[3]
            for r in range(7):
                for c in range(r, 7):
                    s = P[r, c] - (W[0, r] * W[0, c] + W[1, r] * W[1, c] + W[2, r] * W[2, c] + W[3, r] * W[3, c])
                    P[r, c] = s
                    P[c, r] = s
        if use_rest and at_rest:
            # bias pseudo-measurement: gyro low-pass = b, three scalar updates (H = e_{4+i})
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
        nq = math.sqrt(x[0] * x[0] + x[1] * x[1] + x[2] * x[2] + x[3] * x[3])
        inv = 1.0 / nq
        for i in range(4):
            x[i] *= inv
            out_q[k, i] = x[i]
        for i in range(3):
            out_b[k, i] = x[4 + i]


@njit(cache=True)
def mag_dist_state_nb():
    s = np.zeros(11)
    s[3] = -1.0
    s[6] = 1.0
    return s


_EXTRA = (
    Real("tau_acc_s", fixed=0.0, unit="s", doc="earth-frame acc low-pass time constant (0: raw acc)"),
    Real("mag_rejection", fixed=False, doc="magnetic disturbance rejection (robust block a)"),
    Real("rest_bias", fixed=False, doc="gyro bias from rest detection (robust block b)"),
    Real("r_rest", fixed=3e-6, unit="(rad/s)^2", doc="variance of the rest bias pseudo-measurement"),
    Real("mag_max_rejection_s", fixed=60.0, unit="s", doc="longest full rejection of a disturbed field"),
    Real("mag_norm_th", fixed=0.1, unit="1", doc="relative field-norm threshold"),
    Real("mag_dip_th_deg", fixed=10.0, unit="deg", doc="dip-angle threshold"),
)


class EKFRobustProto(EKF):
    """Prototype EKF with robust blocks (see the module docstring); EKF parameters plus ``_EXTRA``."""

    name: ClassVar[str] = "ekf_robust_proto"
    params: ClassVar[tuple[Real, ...]] = _EKF_PARAMS + _EXTRA
    defaults: ClassVar[dict[str, Any]] = {**_EKF_DEFAULTS, "tau_acc_s": 0.0, "mag_rejection": False,
                                          "rest_bias": False, "r_rest": 3e-6, "mag_max_rejection_s": 60.0,
                                          "mag_norm_th": 0.1, "mag_dip_th_deg": 10.0}

    def _run(self, rec: Recording, q0: np.ndarray) -> FilterResult:
        v = self.values
        gyr, acc, mag, use_mag = self._inputs(rec)
        n = rec.n
        out_q, out_b, out_d = np.empty((n, 4)), np.empty((n, 3)), np.empty((n, 2))
        x0 = np.zeros(7)
        x0[:4] = q0
        g = gravity_in_units(rec)
        coef = self.coefficients(rec.dt, use_mag, g)
        tau = float(v["tau_acc_s"])
        if tau < 0 or not math.isfinite(tau):
            raise ValueError(f"{self.name}: tau_acc_s must be >= 0, got {tau!r}")
        flags = np.array([float(bool(v["mag_rejection"])), float(bool(v["rest_bias"])), float(tau > 0),
                          float(v["r_rest"])])
        mcoef = mag_dist_coefficients(rec.dt, norm_th=float(v["mag_norm_th"]), dip_th_deg=float(v["mag_dip_th_deg"]),
                                      max_rejection_s=float(v["mag_max_rejection_s"]))
        rcoef = rest_coefficients(rec.dt, th_acc=0.5 * g / 9.81)
        acoef = acc_lp_coefficients(rec.dt, tau_acc_s=tau, gravity=g)
        _kernel(gyr, acc, mag, coef, flags, mcoef, rcoef, acoef, x0, out_q, out_b, out_d)
        return FilterResult(out_q, self.working_frame, {"gyr_bias": out_b, "mag_gain": out_d[:, 0],
                                                        "rest": out_d[:, 1]})
