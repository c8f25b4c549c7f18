"""Numba kernel of ``valenti`` (:mod:`objectives.attitude.filters.valenti`): Valenti, Dryanovski and Xiao's
complementary filter (Sensors 2015, 15(8), 19302-19330; equations numbered as in the paper) as the ROS node
``imu_complementary_filter`` runs it, its start from the first sample, and its layouts.

The state quaternion is the paper's ``^L_G q`` (the global frame's orientation in the local frame: earth to
sensor, global frame NWU, x on magnetic north with a magnetometer); the output is its inverse, sensor to earth.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from objectives.attitude.filters._scalar import qmul
from objectives.attitude.filters.layout import Layout

__all__ = ["C", "S", "coefficients", "initial_state", "valenti_kernel", "G_NODE", "STEADY", "ADAPTIVE"]

#: the node's gravity, m/s^2 (adaptive gain and steady state compare |a| with it)
G_NODE = 9.81
#: the node's steady-state thresholds: |a| within 0.1 m/s^2 of G_NODE, each rate within 0.01 rad/s of the last
#: sample's and within 0.2 rad/s of the bias estimate
TH_ACC, TH_DELTA_GYR, TH_GYR = 0.1, 0.01, 0.2
STEADY = {"acc": TH_ACC, "delta_gyr": TH_DELTA_GYR, "gyr": TH_GYR}
#: the paper's adaptive gain thresholds t1, t2 on the relative magnitude error (eq. 61)
ADAPTIVE = (0.1, 0.2)
#: below this the paper interpolates by SLERP, above by LERP (section 5.2.1: epsilon = 0.9)
EPS_LERP = 0.9

C = Layout("C", (("DT", 1, "sample time, s"),
                 ("GAIN_ACC", 1, "alpha: accelerometer correction gain (eqs. 48-52)"),
                 ("GAIN_MAG", 1, "beta: magnetometer correction gain (eqs. 54-58)"),
                 ("BIAS_ALPHA", 1, "gain of the gyro bias low-pass at steady state"),
                 ("DO_BIAS", 1, "1: estimate the gyro bias at steady state"),
                 ("DO_ADAPTIVE", 1, "1: adaptive accelerometer gain (eqs. 60-61)"),
                 ("USE_MAG", 1, "1: magnetometer correction"),
                 ("G", 1, "the node's gravity G_NODE in the accelerometer's unit")))
S = Layout("S", (("Q", 4, "^L_G q (w, x, y, z): earth (NWU) to sensor"),
                 ("BIAS", 3, "gyro bias estimate, rad/s"),
                 ("PREV", 3, "the last sample's raw rate, rad/s (steady-state test)"),
                 ("PHASE", 1, "0: the next sample starts from acc (and mag); 2: from Q as given; 1: running")))


@njit(cache=True, inline="always")
def _rotate(p0, p1, p2, p3, x, y, z):
    """p (x) v (x) p* for a unit quaternion p."""
    return ((p0 * p0 + p1 * p1 - p2 * p2 - p3 * p3) * x + 2.0 * (p1 * p2 - p0 * p3) * y + 2.0 * (p1 * p3 + p0 * p2) * z,
            2.0 * (p1 * p2 + p0 * p3) * x + (p0 * p0 - p1 * p1 + p2 * p2 - p3 * p3) * y + 2.0 * (p2 * p3 - p0 * p1) * z,
            2.0 * (p1 * p3 - p0 * p2) * x + 2.0 * (p2 * p3 + p0 * p1) * y + (p0 * p0 - p1 * p1 - p2 * p2 + p3 * p3) * z)


@njit(cache=True, inline="always")
def _scale(gain, d0, d1, d2, d3):
    """The fraction ``gain`` of the delta quaternion ``d`` from the identity: LERP (eq. 50) when d0 > 0.9, else
    SLERP (eq. 52), normalised (eq. 51)."""
    if d0 < EPS_LERP:
        om = math.acos(d0)
        so = math.sin(om)
        a = math.sin((1.0 - gain) * om) / so
        b = math.sin(gain * om) / so
        d0, d1, d2, d3 = a + b * d0, b * d1, b * d2, b * d3
    else:
        d0, d1, d2, d3 = (1.0 - gain) + gain * d0, gain * d1, gain * d2, gain * d3
    n = math.sqrt(d0 * d0 + d1 * d1 + d2 * d2 + d3 * d3)
    return d0 / n, d1 / n, d2 / n, d3 / n


@njit(cache=True, inline="always")
def _gain_factor(e):
    """Eq. 61: 1 below t1, falling linearly to 0 at t2, 0 above."""
    t1, t2 = ADAPTIVE
    if e < t1:
        return 1.0
    if e < t2:
        return (t2 - e) / (t2 - t1)
    return 0.0


@njit(cache=True, inline="always")
def _start(ax, ay, az, mx, my, mz, use_mag):
    """^L_G q from one sample: q_acc of eq. 25, and with the field q_acc (x) q_mag (eqs. 26-36)."""
    n = math.sqrt(ax * ax + ay * ay + az * az)
    ax, ay, az = ax / n, ay / n, az / n
    if az >= 0.0:
        w = math.sqrt((az + 1.0) * 0.5)
        a0, a1, a2, a3 = w, -ay / (2.0 * w), ax / (2.0 * w), 0.0
    else:
        x = math.sqrt((1.0 - az) * 0.5)
        a0, a1, a2, a3 = -ay / (2.0 * x), x, 0.0, ax / (2.0 * x)
    if not use_mag:
        return a0, a1, a2, a3
    # eq. 26: l = R^T(q_acc) m, the field in the tilt-free frame
    lx, ly, _ = _rotate(a0, -a1, -a2, -a3, mx, my, mz)
    gam = lx * lx + ly * ly
    sg = math.sqrt(gam)
    if lx >= 0.0:  # eq. 35, first form
        b = math.sqrt(gam + lx * sg)
        m0, m3 = b / math.sqrt(2.0 * gam), ly / (math.sqrt(2.0) * b)
    else:  # second form
        b = math.sqrt(gam - lx * sg)
        m0, m3 = ly / (math.sqrt(2.0) * b), b / math.sqrt(2.0 * gam)
    return qmul(a0, a1, a2, a3, m0, 0.0, 0.0, m3)  # eq. 36


@njit(cache=True)
def valenti_kernel(gyr, acc, mag, coef, state, out, bias_out):
    """The complementary filter over whole arrays (module docstring).

    Parameters
    ----------
    gyr, acc, mag : (N, 3) float64
        rad/s, the accelerometer in the unit of ``coef[C.G]`` (m/s^2: 9.81), the field in any unit; ``mag``
        (0, 3) without the magnetometer.
    coef : (C.LEN,) float64
        Layout :data:`C`.
    state : (S.LEN,) float64
        Layout :data:`S`, read and written.
    out : (N, 4) float64
        Written: sensor-to-earth (NWU) after each sample.
    bias_out : (N, 3) or (0, 3) float64
        Written when not empty: the bias estimate used at each sample.
    """
    dt, ga, gm, alpha_b = coef[C.DT], coef[C.GAIN_ACC], coef[C.GAIN_MAG], coef[C.BIAS_ALPHA]
    do_bias, do_adapt = coef[C.DO_BIAS] != 0.0, coef[C.DO_ADAPTIVE] != 0.0
    use_mag = coef[C.USE_MAG] != 0.0 and mag.shape[0] == gyr.shape[0]
    g = coef[C.G]
    th_acc = TH_ACC * g / G_NODE
    q0, q1, q2, q3 = state[S.Q], state[S.Q + 1], state[S.Q + 2], state[S.Q + 3]
    bx, by, bz = state[S.BIAS], state[S.BIAS + 1], state[S.BIAS + 2]
    px, py, pz = state[S.PREV], state[S.PREV + 1], state[S.PREV + 2]
    phase = int(state[S.PHASE])
    for i in range(gyr.shape[0]):
        wx, wy, wz = gyr[i, 0], gyr[i, 1], gyr[i, 2]
        ax, ay, az = acc[i, 0], acc[i, 1], acc[i, 2]
        mx = my = mz = 0.0
        if use_mag:
            mx, my, mz = mag[i, 0], mag[i, 1], mag[i, 2]
        if phase != 1:  # the start sample: the orientation from it (or as given), no filtering
            if phase == 0:
                q0, q1, q2, q3 = _start(ax, ay, az, mx, my, mz, use_mag)
            phase = 1
        else:
            an = math.sqrt(ax * ax + ay * ay + az * az)
            if do_bias:  # steady state: the bias follows the rate through a first-order low-pass
                steady = not (abs(an - g) > th_acc
                              or abs(wx - px) > TH_DELTA_GYR or abs(wy - py) > TH_DELTA_GYR
                              or abs(wz - pz) > TH_DELTA_GYR
                              or abs(wx - bx) > TH_GYR or abs(wy - by) > TH_GYR
                              or abs(wz - bz) > TH_GYR)
                if steady:
                    bx += alpha_b * (wx - bx)
                    by += alpha_b * (wy - by)
                    bz += alpha_b * (wz - bz)
                px, py, pz = wx, wy, wz
            ux, uy, uz = wx - bx, wy - by, wz - bz
            # eqs. 38-42: q_w = q + (-1/2 (0, w) (x) q) dt, normalised
            p0 = q0 + 0.5 * dt * (ux * q1 + uy * q2 + uz * q3)
            p1 = q1 + 0.5 * dt * (-ux * q0 - uy * q3 + uz * q2)
            p2 = q2 + 0.5 * dt * (ux * q3 - uy * q0 - uz * q1)
            p3 = q3 + 0.5 * dt * (-ux * q2 + uy * q1 - uz * q0)
            n = math.sqrt(p0 * p0 + p1 * p1 + p2 * p2 + p3 * p3)
            p0, p1, p2, p3 = p0 / n, p1 / n, p2 / n, p3 / n
            # eqs. 44-47: predicted gravity g_p = R^T(q_w) a, delta q_acc
            gx, gy, gz = _rotate(p0, -p1, -p2, -p3, ax / an, ay / an, az / an)
            d0 = math.sqrt((gz + 1.0) * 0.5)
            d1, d2, d3 = -gy / (2.0 * d0), gx / (2.0 * d0), 0.0
            alpha = ga * _gain_factor(abs(an - g) / g) if do_adapt else ga  # eqs. 60-61
            d0, d1, d2, d3 = _scale(alpha, d0, d1, d2, d3)
            q0, q1, q2, q3 = qmul(p0, p1, p2, p3, d0, d1, d2, d3)  # eq. 53
            if use_mag:
                # eqs. 54-58: l = R^T(q') m, delta q_mag
                lx, ly, _ = _rotate(q0, -q1, -q2, -q3, mx, my, mz)
                gam = lx * lx + ly * ly
                b = math.sqrt(gam + lx * math.sqrt(gam))
                d0, d1, d2, d3 = _scale(gm, b / math.sqrt(2.0 * gam), 0.0, 0.0, ly / (math.sqrt(2.0) * b))
                q0, q1, q2, q3 = qmul(q0, q1, q2, q3, d0, d1, d2, d3)  # eq. 59
            n = math.sqrt(q0 * q0 + q1 * q1 + q2 * q2 + q3 * q3)
            q0, q1, q2, q3 = q0 / n, q1 / n, q2 / n, q3 / n
        out[i, 0], out[i, 1], out[i, 2], out[i, 3] = q0, -q1, -q2, -q3
        if bias_out.shape[0] > 0:
            bias_out[i, 0], bias_out[i, 1], bias_out[i, 2] = bx, by, bz
    state[S.Q], state[S.Q + 1], state[S.Q + 2], state[S.Q + 3] = q0, q1, q2, q3
    state[S.BIAS], state[S.BIAS + 1], state[S.BIAS + 2] = bx, by, bz
    state[S.PREV], state[S.PREV + 1], state[S.PREV + 2] = px, py, pz
    state[S.PHASE] = float(phase)


def coefficients(v: dict, dt: float, use_mag: bool, g_ref: float) -> np.ndarray:
    """The coefficient array (layout :data:`C`) from validated values; ``g_ref`` is standard gravity in the
    accelerometer's unit (the node's 9.81 m/s^2 is scaled by it)."""
    return C.pack(DT=float(dt), GAIN_ACC=float(v["gain_acc"]), GAIN_MAG=float(v["gain_mag"]),
                  BIAS_ALPHA=float(v["bias_alpha"]), DO_BIAS=1.0 if v["do_bias_estimation"] else 0.0,
                  DO_ADAPTIVE=1.0 if v["do_adaptive_gain"] else 0.0, USE_MAG=1.0 if use_mag else 0.0,
                  G=G_NODE * float(g_ref) / 9.80665)


def initial_state(q0: np.ndarray | None) -> np.ndarray:
    """The start state (layout :data:`S`): from ``q0`` (sensor-to-earth, NWU) when given, else the node's start
    from the first sample."""
    st = np.zeros(S.LEN)
    if q0 is None:
        st[S.Q] = 1.0
    else:
        q = np.asarray(q0, float) / np.linalg.norm(q0)
        st[S.Q:S.Q + 4] = (q[0], -q[1], -q[2], -q[3])
        st[S.PHASE] = 2.0
    return st
