"""The LCF / NCF / CCF kernel with the robust blocks of :mod:`objectives.attitude.filters.robust` (CCF options).

The recursion of Narkhede et al. 2021, eqs. (1)-(14) (see :mod:`~objectives.attitude.filters.complementary`'s
docstring), with two optional blocks; with both off it is the paper's filter bit for bit
(``complementary._cf_kernel`` calls it so: the recursion is written once).

- Block (c), ``acc_lp_tau_s > 0``: the measurement angles of eqs. (4)-(5) (and the tilt compensation of
  eq. (6)) come from the accelerometer low-passed in the earth frame with the current estimate (VQF,
  Laidig & Seel 2023, section 3.2): over a translation that starts and ends at rest the linear
  acceleration averages out while gravity stays, so fast translation no longer drags roll and pitch.
  Only usable raw samples update the low-pass; ``acc_gate`` still tests the raw ``|acc|``.
- Block (a), ``mag_rejection``: the magnetometer rotated into the level frame of the current roll and
  pitch (heading does not matter) is compared with a reference field (norm and dip) learned while
  undisturbed; the yaw correction (PI error of eq. (10) and the blend of eq. (14)) is multiplied by the
  block's gain: 1 undisturbed, 0 while disturbed (the yaw follows the gyroscope), ``1 / rejection_factor``
  after ``mag_max_rejection_s``. Until a first reference is accepted the gain is 1. The gyro low-pass the
  block needs for accepting a new field is the rest block's (b) (its rest flag is not used).
- ``mag_weight`` in [0, 1] (1: the paper): a constant factor on the yaw correction (the same place as block
  (a)'s gain), so the heading is corrected more slowly than roll and pitch, as VQF's magnetometer time
  constant ``tauMag`` (9 s) is longer than its accelerometer's ``tauAcc`` (3 s). A disturbance block (a)
  cannot see (a magnet attached to the sensor from the start rotates with it, so there is no undisturbed
  reference to compare with) then turns the heading less, while fast rotations keep the inclination
  correction they need.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from objectives.attitude.filters._cf_steps import _blend, _mag_yaw, _pi_step, _quat_zyx, _read_mag, _wrap
from objectives.attitude.filters._scalar import read_rate, sq_norm_ok
from objectives.attitude.filters.robust import (
    _acc_lp_update,
    _mag_dist_update,
    _rest_update,
    acc_lp_state,
    mag_dist_state,
    rest_state,
)
from objectives.jit import uncached

__all__ = ["cf_robust_kernel", "cf_robust_inner", "robust_states"]

_PI = math.pi


def robust_states() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Initial states of blocks (a), (b), (c) as :func:`cf_robust_kernel` expects them (no reference field)."""
    return mag_dist_state(), rest_state(), acc_lp_state()


@njit(cache=True)
def cf_robust_kernel(gyr, acc, mag, coef, flags, mcoef, rcoef, acoef, state, ms, rs, ast, out, euler_out,
                     bias_out, gain_out):
    """LCF / NCF / CCF over whole arrays with blocks (a) and (c) (module docstring).

    Parameters
    ----------
    gyr, acc, mag, coef, state, out, euler_out, bias_out
        As ``complementary._cf_kernel``.
    flags : (3,) float64
        ``mag_rejection`` and ``acc_lp`` (1/0), ``mag_weight`` (factor on the yaw correction, 1: none).
    mcoef, rcoef, acoef : float64 arrays
        ``robust.mag_dist_coefficients``, ``robust.rest_coefficients``, ``robust.acc_lp_coefficients``.
    ms, rs, ast : float64 arrays
        States of blocks (a), (b), (c) (:func:`robust_states`), read and written (streaming).
    gain_out : (N,) or (0,) float64
        Written when not empty: the factor on the yaw correction per sample, block (a)'s gain times
        ``mag_weight`` (1 with neither).
    """
    dt, alpha, kp, ki = coef[0], coef[1], coef[2], coef[3]
    use_mag = coef[4] != 0.0 and mag.shape[0] == gyr.shape[0]
    gate = coef[5] if coef.shape[0] > 5 else math.inf
    g_ref = coef[6] if coef.shape[0] > 6 else 1.0
    static = coef.shape[0] > 7 and coef[7] != 0.0
    use_rej = flags[0] != 0.0
    use_alp = flags[1] != 0.0
    w_mag = flags[2]
    w_euler = euler_out.shape[0] == gyr.shape[0]
    w_bias = bias_out.shape[0] == gyr.shape[0]
    w_gain = gain_out.shape[0] == gyr.shape[0]
    blend = 1.0 - alpha
    qb = np.empty(4)
    a_lp = np.empty(3)
    phi, th, psi = state[0], state[1], state[2]
    i0, i1, i2 = state[3], state[4], state[5]
    for i in range(gyr.shape[0]):
        p, q, r = read_rate(gyr, i)
        sp = math.sin(phi)
        cp = math.cos(phi)
        st = math.sin(th)
        ct = math.cos(th)
        if abs(ct) < 1e-6:
            ct = 1e-6 if ct >= 0.0 else -1e-6
        u = q * sp + r * cp
        d0 = p + u * st / ct
        d1 = q * cp - r * sp
        d2 = u / ct
        dx = -acc[i, 0]
        dy = -acc[i, 1]
        dz = -acc[i, 2]
        an, acc_ok = sq_norm_ok(dx, dy, dz)
        if use_alp and acc_ok:
            # block (c): earth-frame low-pass with the current estimate, back in sensor coordinates
            qb[0], qb[1], qb[2], qb[3] = _quat_zyx(phi, th, psi)
            _acc_lp_update(ast, acoef, qb, -dx, -dy, -dz, a_lp)
            dx, dy, dz = -a_lp[0], -a_lp[1], -a_lp[2]
            _, acc_ok = sq_norm_ok(dx, dy, dz)
        if acc_ok and gate < math.inf:
            acc_ok = abs(math.sqrt(an) - g_ref) <= gate * g_ref
        mx, my, mz, mag_ok = _read_mag(mag, i, use_mag)
        gm = w_mag
        if use_rej:
            _rest_update(rs, rcoef, p, q, r, -acc[i, 0], -acc[i, 1], -acc[i, 2])
            if mag_ok:
                # block (a): the field in the level frame of the current roll and pitch, z up
                v2 = sp * my + cp * mz
                lx = math.cos(th) * mx + st * v2
                ly = cp * my - sp * mz
                lz = -st * mx + math.cos(th) * v2
                gl = math.sqrt(rs[0] * rs[0] + rs[1] * rs[1] + rs[2] * rs[2])
                gm = _mag_dist_update(ms, mcoef, lx, ly, -lz, gl)
                gm = w_mag if ms[0] == 0.0 else gm * w_mag
        if w_gain:
            gain_out[i] = gm
        yaw_ok = acc_ok and mag_ok and gm > 0.0
        phi_a = 0.0
        th_a = 0.0
        psi_m = 0.0
        if acc_ok:
            phi_a = math.atan2(dy, dz)
            spa = math.sin(phi_a)
            cpa = math.cos(phi_a)
            th_a = math.atan2(-dx, dy * spa + dz * cpa)
            e0 = _wrap(phi_a - phi)
            e1 = _wrap(th_a - th)
            e2 = 0.0
            if yaw_ok:
                psi_m = _mag_yaw(mx, my, mz, spa, cpa, math.sin(th_a), math.cos(th_a))
                e2 = gm * _wrap(psi_m - psi)
            if static:
                e0 *= alpha
                e1 *= alpha
                e2 *= alpha
            i0, d0 = _pi_step(e0, i0, d0, kp, ki, dt)
            i1, d1 = _pi_step(e1, i1, d1, kp, ki, dt)
            if yaw_ok:
                i2, d2 = _pi_step(e2, i2, d2, kp, ki, dt)
        d0 += i0
        d1 += i1
        d2 += i2
        if w_bias:
            bias_out[i, 0] = -i0
            bias_out[i, 1] = -i1
            bias_out[i, 2] = -i2
        phi = phi + dt * d0
        th = th + dt * d1
        psi = psi + dt * d2
        if th > 0.5 * _PI:
            th = _PI - th
            phi += _PI
            psi += _PI
        elif th < -0.5 * _PI:
            th = -_PI - th
            phi += _PI
            psi += _PI
        o0, o1, o2 = phi, th, psi
        if acc_ok and blend != 0.0:
            o0 = _blend(phi, phi_a, blend)
            o1 = _blend(th, th_a, blend)
            if yaw_ok:
                o2 = _blend(psi, psi_m, blend * gm)
        o0 = _wrap(o0)
        o2 = _wrap(o2)
        if static:
            phi = _wrap(phi)
            psi = _wrap(psi)
        else:
            phi, th, psi = o0, o1, o2
        if w_euler:
            euler_out[i, 0] = o0
            euler_out[i, 1] = o1
            euler_out[i, 2] = o2
        out[i, 0], out[i, 1], out[i, 2], out[i, 3] = _quat_zyx(o0, o1, o2)
    state[0], state[1], state[2] = phi, th, psi
    state[3], state[4], state[5] = i0, i1, i2


#: the uncached twin other kernels call (objectives.jit)
cf_robust_inner = uncached(cf_robust_kernel)
