"""Numba kernel of the LCF / NCF / CCF, with the robust blocks of :mod:`objectives.attitude.filters.robust`
(CCF options), its layouts and the Euler-angle conversions of its state.

The recursion of Narkhede et al. 2021, eqs. (1)-(14) (see :mod:`objectives.attitude.filters.complementary.filters`'s
docstring), with two optional blocks; with both off it is the paper's filter bit for bit
(:func:`cf_kernel` calls it so: the recursion is written once). Layouts: the coefficient array :data:`C`, the
state :data:`X` (declared once; the C port's sizes come from them).

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

from objectives.attitude.filters._scalar import read_rate, sq_norm_ok
from objectives.attitude.filters.complementary.steps import _blend, _mag_yaw, _pi_step, _quat_zyx, _read_mag, _wrap
from objectives.attitude.filters.layout import Layout
from objectives.attitude.filters.robust import (
    _mag_dist_update,
    _rest_update,
    acc_lp_state,
    acc_lp_step,
    mag_dist_state,
    rest_state,
)
from objectives.jit import uncached

__all__ = ["C", "X", "cf_kernel", "cf_robust_kernel", "cf_robust_inner", "robust_states", "coefficients",
           "start_state", "run_arrays", "quat_from_euler_zyx", "euler_zyx_from_quat"]

_PI = math.pi

#: the coefficient array (the entries after USE_MAG may be left out: gate off, g 1, alpha fed back)
C = Layout("C", (("DT", 1, "sample time, s"),
                 ("ALPHA", 1, "gyro weight per sample, eq. (8) (1: no blend)"),
                 ("KP", 1, "proportional gain, 1/s (eq. (10))"),
                 ("KI", 1, "integral gain, 1/s^2 (eq. (10))"),
                 ("USE_MAG", 1, "1: yaw from the magnetometer, 0: from the gyro only"),
                 ("GATE", 1, "acc_gate: no correction when | |acc| - g | > acc_gate g (inf: off)"),
                 ("G", 1, "gravity in the accelerometer's unit"),
                 ("STATIC", 1, "1: eq. (14) as written (a static output weight), 0: alpha fed back per sample")))
#: the state: the Euler angles and the PI integrals
X = Layout("X", (("EULER", 3, "roll, pitch, yaw (ZYX, NED), rad"), ("INTEG", 3, "the PI integrals I, rad/s")))


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
        As :func:`cf_kernel`.
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
    dt, alpha, kp, ki = coef[C.DT], coef[C.ALPHA], coef[C.KP], coef[C.KI]
    use_mag = coef[C.USE_MAG] != 0.0 and mag.shape[0] == gyr.shape[0]
    gate = coef[C.GATE] if coef.shape[0] > C.GATE else math.inf
    g_ref = coef[C.G] if coef.shape[0] > C.G else 1.0
    static = coef.shape[0] > C.STATIC and coef[C.STATIC] != 0.0
    use_rej = flags[0] != 0.0
    use_alp = flags[1] != 0.0
    w_mag = flags[2]
    w_euler = euler_out.shape[0] == gyr.shape[0]
    w_bias = bias_out.shape[0] == gyr.shape[0]
    w_gain = gain_out.shape[0] == gyr.shape[0]
    blend = 1.0 - alpha
    phi, th, psi = state[X.EULER], state[X.EULER + 1], state[X.EULER + 2]
    i0, i1, i2 = state[X.INTEG], state[X.INTEG + 1], state[X.INTEG + 2]
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
            b0, b1, b2, b3 = _quat_zyx(phi, th, psi)
            ast[0], ast[1], ast[2], ast[3], lpx, lpy, lpz = acc_lp_step(
                acoef[0], ast[0], ast[1], ast[2], ast[3], b0, b1, b2, b3, -dx, -dy, -dz)
            dx, dy, dz = -lpx, -lpy, -lpz
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
    state[X.EULER], state[X.EULER + 1], state[X.EULER + 2] = phi, th, psi
    state[X.INTEG], state[X.INTEG + 1], state[X.INTEG + 2] = i0, i1, i2


#: the uncached twin other kernels call (objectives.jit)
cf_robust_inner = uncached(cf_robust_kernel)


@njit(cache=True)
def cf_kernel(gyr, acc, mag, coef, state, out, euler_out, bias_out):
    """LCF / NCF / CCF over whole arrays (see module docstring for the equations).

    Parameters
    ----------
    gyr, acc, mag : (N, 3) float64
        rad/s, any unit, any unit; ``mag`` may be (0, 3).
    coef : (5,), (7,) or (C.LEN,) float64
        Layout :data:`C`: ``dt`` s, ``alpha`` (1 = no LCF blend), ``Kp`` 1/s, ``Ki`` 1/s^2, ``use_mag`` (0/1); optional
        ``acc_gate`` (inf: off) and ``g`` (gravity in acc units): samples with
        ``| |acc| - g | > acc_gate g`` are treated as unusable accelerometer samples; optional
        ``static`` (0: the blend is fed back per sample, eq. (8) discretised; 1: eq. (14) read as
        written, a static output weight, the state being the integrator of eq. (14)).
    state : (X.LEN,) float64
        Layout :data:`X`, read and written: roll, pitch, yaw, rad (ZYX, NED), and the integrals ``I``, rad/s; in: before
        the first sample, out: after the last (for streaming). With ``static`` the angles are the
        integrator's, not the output's.
    out : (N, 4) float64
        Written: sensor-to-earth quaternion (NED) of the estimate after each sample.
    euler_out, bias_out : (N, 3) or (0, 3) float64
        Written when not empty: the Euler estimate, rad; the Euler-rate bias estimate ``-I``, rad/s.

    The recursion is :func:`cf_robust_kernel`'s with both blocks off
    (their gain 1 multiplies exactly, so these are the paper's operations, bit for bit).
    """
    off = np.zeros(3)
    off[2] = 1.0  # no rejection, no low-pass, mag_weight 1
    none = np.empty(0)
    cf_robust_inner(gyr, acc, mag, coef, off, none, none, none, state, none, none, none, out, euler_out, bias_out,
                    none)


def quat_from_euler_zyx(euler: np.ndarray) -> np.ndarray:
    """Quaternions ``q_z(yaw) q_y(pitch) q_x(roll)`` of (N, 3) or (3,) ``(roll, pitch, yaw)``, rad."""
    e = np.asarray(euler, dtype=float)
    h = 0.5 * e
    c1, c2, c3 = np.cos(h[..., 0]), np.cos(h[..., 1]), np.cos(h[..., 2])
    s1, s2, s3 = np.sin(h[..., 0]), np.sin(h[..., 1]), np.sin(h[..., 2])
    return np.stack([c1 * c2 * c3 + s1 * s2 * s3, s1 * c2 * c3 - c1 * s2 * s3,
                     c1 * s2 * c3 + s1 * c2 * s3, c1 * c2 * s3 - s1 * s2 * c3], axis=-1)


def euler_zyx_from_quat(q: np.ndarray) -> np.ndarray:
    """``(roll, pitch, yaw)``, rad, of (N, 4) or (4,) quaternions (inverse of :func:`quat_from_euler_zyx`)."""
    q = np.asarray(q, dtype=float)
    w, x, y, z = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    roll = np.arctan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y))
    pitch = np.arcsin(np.clip(2 * (w * y - z * x), -1.0, 1.0))
    yaw = np.arctan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
    return np.stack([roll, pitch, yaw], axis=-1)


def coefficients(dt: float, alpha: float, kp: float, ki: float, has_mag: bool, acc_gate: float, g_ref: float,
          static: bool = False) -> np.ndarray:
    """The kernel's coefficient array (the only place it is built)."""
    return C.pack(DT=dt, ALPHA=alpha, KP=kp, KI=ki, USE_MAG=1.0 if has_mag else 0.0, GATE=acc_gate, G=g_ref,
                  STATIC=1.0 if static else 0.0)


def start_state(euler0: np.ndarray) -> np.ndarray:
    """The kernel's start state (layout :data:`X`): the Euler angles ``euler0`` (rad) and zero integrals."""
    return X.pack(EULER=euler0, INTEG=(0.0, 0.0, 0.0))


def run_arrays(gyr, acc, mag, coef: np.ndarray, state: np.ndarray, detailed: bool):
    """Kernel call from ``state`` (written: the state after the last sample) on checked contiguous arrays."""
    n = gyr.shape[0]
    out = np.empty((n, 4))
    m = n if detailed else 0
    euler = np.empty((m, 3))
    bias = np.empty((m, 3))
    cf_kernel(gyr, acc, mag, coef, state, out, euler, bias)
    return (out, euler, bias) if detailed else out
