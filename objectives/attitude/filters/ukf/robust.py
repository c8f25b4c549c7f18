"""Robust blocks of :mod:`objectives.attitude.filters.robust` around the QUKF/QRAUKF kernel.

The paper's kernel (:func:`objectives.attitude.filters.ukf.kernel._ukf_run`) is not changed: it
carries its whole state between calls, so this driver runs it one sample at a time and applies the
blocks between samples, with the attitude forecast for the sample (the previous estimate propagated by
eq. 17 with the previous gyro sample and the bias estimate, noise-free):

- (c) ``acc_lp``: the accelerometer of sample ``k`` is replaced by its low-pass in the (ENU) earth
  frame rotated back into the sensor frame (:func:`~objectives.attitude.filters.robust.acc_lp_step`):
  the tilt of the pseudo-measurement (eqs. 22-23) holds through fast translation.
- (a) ``mag_rejection``: the magnetometer rotated into the earth frame (z up) feeds
  :func:`~objectives.attitude.filters.robust._mag_dist_update` (field norm and dip against a reference
  learned while undisturbed, with its time limit). With gain ``g < 1`` the magnetometer handed to the
  kernel is ``g`` times the measured horizontal field direction plus ``1 - g`` times the predicted one
  (earth north rotated into the sensor frame), both perpendicular to the accelerometer vector used: the
  algebraic quaternion of eq. 24 then keeps the predicted heading (``g = 0``) and still corrects tilt.
- (b) ``rest_bias``: :func:`~objectives.attitude.filters.robust._rest_update` detects rest; at rest the
  low-passed gyro measures the bias part of the state: three scalar Kalman updates with variance
  ``r_rest`` on the 6-D error state (attitude correction applied as ``R2Q(dx) * e``, eq. 4).

With every block off the driver is not used and the output is the paper's kernel's, bit for bit.

Numba caches this driver's loop with the kernel compiled into it; rule 3 of :mod:`objectives.jit` keys the
cache entry on all the package's sources, so an edit of ``kernel.py``, ``mean.py`` or ``scalar.py`` recompiles
it too.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from objectives.attitude.filters._scalar import qmul
from objectives.attitude.filters.robust import (
    _mag_dist_update,
    _rest_update,
    _rot,
    acc_lp_state,
    acc_lp_step,
    mag_dist_state,
    rest_state,
)
from objectives.attitude.filters.ukf.kernel import C, I, S, _ukf_run_inner
from objectives.attitude.filters.ukf.scalar import _r2q

__all__ = ["ukf_robust_run"]


@njit
def _rest_bias_update(state, g_lp, r_rest):
    """Three scalar Kalman updates: the low-passed gyro ``g_lp`` (3,) rad/s measures the bias (``S.BIAS``)."""
    P = state[S.P:S.P + 36].reshape((6, 6))
    for i in range(3):
        j = 3 + i
        s = P[j, j] + r_rest
        if not s > 0.0:
            continue
        y = g_lp[i] - state[S.BIAS + i]
        c0, c1, c2 = P[0, j] * y / s, P[1, j] * y / s, P[2, j] * y / s
        p0, p1, p2, p3 = _r2q(c0, c1, c2)
        state[S.Q], state[S.Q + 1], state[S.Q + 2], state[S.Q + 3] = qmul(p0, p1, p2, p3, state[S.Q], state[S.Q + 1],
                                                                          state[S.Q + 2], state[S.Q + 3])
        for m in range(3):
            state[S.BIAS + m] += P[3 + m, j] * y / s
        # P = P - P[:, j] P[j, :] / s (symmetric rank-one downdate)
        for r in range(6):
            for c in range(r + 1):
                v = P[r, c] - P[r, j] * P[c, j] / s
                P[r, c] = v
                P[c, r] = v


@njit(cache=True)
def _ukf_robust_loop(gyr, acc, mag, coef, robust, state, istate, work, flags, mcoef, rcoef, acoef, ms, rs, ast,
                     out_q, out_bias, out_lam, out_skip, out_fallback, out_d):
    use_rej, use_rest, use_alp, r_rest = flags[0] != 0.0, flags[1] != 0.0, flags[2] != 0.0, flags[3]
    a_in = np.empty((1, 3))
    m_in = np.empty((1, 3))
    q = np.empty(4)
    g_lp = np.empty(3)
    dt = coef[C.DT]
    for k in range(gyr.shape[0]):
        # the attitude the kernel forecasts for sample k (eq. 17 with gyr[k-1] and the bias, noise-free)
        q[0], q[1], q[2], q[3] = state[S.Q], state[S.Q + 1], state[S.Q + 2], state[S.Q + 3]
        wx = state[S.GYR] - state[S.BIAS]
        wy = state[S.GYR + 1] - state[S.BIAS + 1]
        wz = state[S.GYR + 2] - state[S.BIAS + 2]
        if istate[I.SEEN] > 0 and math.isfinite(wx + wy + wz):
            d0, d1, d2, d3 = _r2q(wx * dt, wy * dt, wz * dt)
            q[0], q[1], q[2], q[3] = qmul(q[0], q[1], q[2], q[3], d0, d1, d2, d3)
        ax, ay, az = acc[k, 0], acc[k, 1], acc[k, 2]
        mx, my, mz = mag[k, 0], mag[k, 1], mag[k, 2]
        at_rest = False
        if use_rest or use_rej:
            at_rest = _rest_update(rs, rcoef, gyr[k, 0], gyr[k, 1], gyr[k, 2], ax, ay, az)
        if use_alp and math.isfinite(ax + ay + az):
            ast[0], ast[1], ast[2], ast[3], ax, ay, az = acc_lp_step(
                acoef[0], ast[0], ast[1], ast[2], ast[3], q[0], q[1], q[2], q[3], ax, ay, az)
        gm = 1.0
        if use_rej and math.isfinite(mx + my + mz):
            ex, ey, ez = _rot(q[0], q[1], q[2], q[3], mx, my, mz, 1.0)  # ENU: z up, as the block expects
            gl = math.sqrt(rs[0] * rs[0] + rs[1] * rs[1] + rs[2] * rs[2])
            gm = _mag_dist_update(ms, mcoef, ex, ey, ez, gl)
            if ms[0] == 0.0:  # no reference field yet: nothing to compare with
                gm = 1.0
            an = math.sqrt(ax * ax + ay * ay + az * az)
            if gm < 1.0 and an > 0.0:
                ux, uy, uz = ax / an, ay / an, az / an
                dm = mx * ux + my * uy + mz * uz
                hx, hy, hz = mx - dm * ux, my - dm * uy, mz - dm * uz
                hn = math.sqrt(hx * hx + hy * hy + hz * hz)
                nx, ny, nz = _rot(q[0], q[1], q[2], q[3], 0.0, 1.0, 0.0, -1.0)  # earth north in the sensor frame
                dn = nx * ux + ny * uy + nz * uz
                px, py, pz = nx - dn * ux, ny - dn * uy, nz - dn * uz
                pn = math.sqrt(px * px + py * py + pz * pz)
                if hn > 0.0 and pn > 0.0:
                    mx = gm * hx / hn + (1.0 - gm) * px / pn
                    my = gm * hy / hn + (1.0 - gm) * py / pn
                    mz = gm * hz / hn + (1.0 - gm) * pz / pn
        a_in[0, 0], a_in[0, 1], a_in[0, 2] = ax, ay, az
        m_in[0, 0], m_in[0, 1], m_in[0, 2] = mx, my, mz
        _ukf_run_inner(gyr[k:k + 1], a_in, m_in, coef, robust, state, istate, work, out_q[k:k + 1], out_bias[k:k + 1],
                 out_lam[k:k + 1], out_skip[k:k + 1], out_fallback[k:k + 1])
        if use_rest and at_rest:
            g_lp[0], g_lp[1], g_lp[2] = rs[0], rs[1], rs[2]
            _rest_bias_update(state, g_lp, r_rest)
            for j in range(4):
                out_q[k, j] = state[S.Q + j]
            out_bias[k, 0], out_bias[k, 1], out_bias[k, 2] = state[S.BIAS], state[S.BIAS + 1], state[S.BIAS + 2]
        out_d[k, 0] = gm
        out_d[k, 1] = 1.0 if at_rest else 0.0


def ukf_robust_run(gyr: np.ndarray, acc: np.ndarray, mag: np.ndarray, coef: np.ndarray, robust: bool,
                   state: np.ndarray, istate: np.ndarray, work: np.ndarray, flags: np.ndarray, mcoef: np.ndarray,
                   rcoef: np.ndarray, acoef: np.ndarray, states: tuple | None = None) -> dict[str, np.ndarray]:
    """The kernel with the robust blocks over a whole recording (contiguous float64 (N, 3) arrays).

    ``flags`` (4,): mag_rejection, rest_bias, acc_lp (1/0), rest variance (rad/s)^2; ``mcoef``, ``rcoef``,
    ``acoef`` from :mod:`objectives.attitude.filters.robust`; ``states``: the blocks' states ``(ms, rs, ast)``,
    updated in place (None: their start states). Returns the kernel's outputs plus ``mag_gain`` (N,) and
    ``rest`` (N,) bool.
    """
    ms, rs, ast = states if states is not None else (mag_dist_state(), rest_state(), acc_lp_state())
    n = gyr.shape[0]
    out = {"quat": np.empty((n, 4)), "bias": np.empty((n, 3)), "lam": np.empty((n, 3)),
           "skipped": np.zeros(n, dtype=np.bool_), "fallback": np.zeros(n, dtype=np.bool_)}
    d = np.empty((n, 2))
    _ukf_robust_loop(gyr, acc, mag, coef, bool(robust), state, istate, work, flags, mcoef, rcoef, acoef,
                     ms, rs, ast, out["quat"], out["bias"],
                     out["lam"], out["skipped"], out["fallback"], d)
    out["mag_gain"] = d[:, 0]
    out["rest"] = d[:, 1] != 0.0
    return out
