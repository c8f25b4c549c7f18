"""Numba kernel of ``imu_tools_madgwick`` (:mod:`objectives.attitude.filters.imu_tools_madgwick`): the per-sample
update of the ROS node ``imu_filter_madgwick`` (Madgwick's report eqs. 11-13, 20-21, 25-34, 42-49 in the node's
world frames), its stateless start from the first sample, the kernel over whole arrays and its layouts.

Layouts: the coefficient array :data:`C`, the state :data:`S` (declared once; the C port's enums come from them).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from objectives.attitude.filters.layout import Layout

__all__ = ["C", "S", "FRAMES", "coefficients", "initial_state", "imu_tools_madgwick_kernel"]

#: world_frame -> code in the coefficients (the node's enum order: ENU, NED, NWU)
FRAMES = {"enu": 0, "ned": 1, "nwu": 2}

C = Layout("C", (("DT", 1, "sample time, s (stamps' difference; 0 on the start sample)"),
                 ("GAIN", 1, "gradient step gain beta, rad/s (report eq. 33)"),
                 ("ZETA", 1, "gyro drift gain zeta, 1/s (report eq. 48)"),
                 ("FRAME", 1, "world frame: 0 ENU, 1 NED, 2 NWU"),
                 ("USE_MAG", 1, "1: MARG update, 0: IMU update"),
                 ("MAG_BIAS", 3, "magnetometer bias subtracted before use, the field's unit")))
S = Layout("S", (("Q", 4, "sensor-to-earth quaternion (w, x, y, z) in the world frame"),
                 ("WB", 3, "gyro drift estimate omega_b, rad/s (report eq. 48)"),
                 ("PHASE", 1, "0: the next sample starts from its stateless orientation, 2: from Q as given; "
                              "1: running")))


@njit(cache=True, inline="always")
def _grad(q0, q1, q2, q3, dx, dy, dz, sx, sy, sz):
    """J^T f of the report's eqs. 20-21: f = q* (x) d (x) q - s for the earth reference ``d`` and the sensor
    measurement ``s`` (unit vectors), J its Jacobian in (q0, q1, q2, q3)."""
    f1 = 2.0 * dx * (0.5 - q2 * q2 - q3 * q3) + 2.0 * dy * (q0 * q3 + q1 * q2) + 2.0 * dz * (q1 * q3 - q0 * q2) - sx
    f2 = 2.0 * dx * (q1 * q2 - q0 * q3) + 2.0 * dy * (0.5 - q1 * q1 - q3 * q3) + 2.0 * dz * (q0 * q1 + q2 * q3) - sy
    f3 = 2.0 * dx * (q0 * q2 + q1 * q3) + 2.0 * dy * (q2 * q3 - q0 * q1) + 2.0 * dz * (0.5 - q1 * q1 - q2 * q2) - sz
    g0 = ((2.0 * dy * q3 - 2.0 * dz * q2) * f1 + (-2.0 * dx * q3 + 2.0 * dz * q1) * f2
          + (2.0 * dx * q2 - 2.0 * dy * q1) * f3)
    g1 = ((2.0 * dy * q2 + 2.0 * dz * q3) * f1 + (2.0 * dx * q2 - 4.0 * dy * q1 + 2.0 * dz * q0) * f2
          + (2.0 * dx * q3 - 2.0 * dy * q0 - 4.0 * dz * q1) * f3)
    g2 = ((-4.0 * dx * q2 + 2.0 * dy * q1 - 2.0 * dz * q0) * f1 + (2.0 * dx * q1 + 2.0 * dz * q3) * f2
          + (2.0 * dx * q0 + 2.0 * dy * q3 - 4.0 * dz * q2) * f3)
    g3 = ((-4.0 * dx * q3 + 2.0 * dy * q0 + 2.0 * dz * q1) * f1 + (-2.0 * dx * q0 - 4.0 * dy * q3 + 2.0 * dz * q2) * f2
          + (2.0 * dx * q1 + 2.0 * dy * q2) * f3)
    return g0, g1, g2, g3


@njit(cache=True, inline="always")
def _rotmat_quat(r00, r01, r02, r10, r11, r12, r20, r21, r22):
    """Unit quaternion (w >= 0) of a rotation matrix (Shepperd's method)."""
    tr = r00 + r11 + r22
    if tr > 0.0:
        s = 2.0 * math.sqrt(1.0 + tr)
        return 0.25 * s, (r21 - r12) / s, (r02 - r20) / s, (r10 - r01) / s
    if r00 > r11 and r00 > r22:
        s = 2.0 * math.sqrt(1.0 + r00 - r11 - r22)
        w, x, y, z = (r21 - r12) / s, 0.25 * s, (r01 + r10) / s, (r02 + r20) / s
    elif r11 > r22:
        s = 2.0 * math.sqrt(1.0 + r11 - r00 - r22)
        w, x, y, z = (r02 - r20) / s, (r01 + r10) / s, 0.25 * s, (r12 + r21) / s
    else:
        s = 2.0 * math.sqrt(1.0 + r22 - r00 - r11)
        w, x, y, z = (r10 - r01) / s, (r02 + r20) / s, (r12 + r21) / s, 0.25 * s
    if w < 0.0:
        return -w, -x, -y, -z
    return w, x, y, z


@njit(cache=True, inline="always")
def _stateless(frame, ax, ay, az, ex, ey, ez):
    """The node's start orientation from gravity ``a`` (pointing up) and a northward reference ``e``: east
    H = e x a, north M = a x H (both unit), the world axes as rows of the sensor-to-earth matrix (ENU: H, M, a;
    NED: M, H, -a; NWU: M, -H, a). ``ok`` is False when |e x a| < 1e-7 (the node's free-fall test)."""
    hx = ey * az - ez * ay
    hy = ez * ax - ex * az
    hz = ex * ay - ey * ax
    nh = math.sqrt(hx * hx + hy * hy + hz * hz)
    if not nh >= 1e-7:
        return False, 1.0, 0.0, 0.0, 0.0
    hx, hy, hz = hx / nh, hy / nh, hz / nh
    na = math.sqrt(ax * ax + ay * ay + az * az)
    ax, ay, az = ax / na, ay / na, az / na
    mx = ay * hz - az * hy
    my = az * hx - ax * hz
    mz = ax * hy - ay * hx
    if frame == 1:  # NED
        w, x, y, z = _rotmat_quat(mx, my, mz, hx, hy, hz, -ax, -ay, -az)
    elif frame == 2:  # NWU
        w, x, y, z = _rotmat_quat(mx, my, mz, -hx, -hy, -hz, ax, ay, az)
    else:  # ENU
        w, x, y, z = _rotmat_quat(hx, hy, hz, mx, my, mz, ax, ay, az)
    return True, w, x, y, z


@njit(cache=True, inline="always")
def _update(q0, q1, q2, q3, bx, by, bz, gx, gy, gz, ax, ay, az, mx, my, mz, marg, dt, gain, zeta, frame):
    """One update of the node (module docstring of the package): the new ``(q, omega_b)``."""
    sgn = -1.0 if frame == 1 else 1.0  # gravity reference: up is -z in NED
    if not (ax == 0.0 and ay == 0.0 and az == 0.0):
        na = 1.0 / math.sqrt(ax * ax + ay * ay + az * az)
        ax, ay, az = ax * na, ay * na, az * na
        s0, s1, s2, s3 = _grad(q0, q1, q2, q3, 0.0, 0.0, sgn, ax, ay, az)  # eq. 25
        if marg:
            nm = 1.0 / math.sqrt(mx * mx + my * my + mz * mz)
            mx, my, mz = mx * nm, my * nm, mz * nm
            # eq. 45: h = q (x) m (x) q*; eq. 46: b = (|h_xy|, 0, h_z), north on the frame's north axis
            hx = ((1.0 - 2.0 * (q2 * q2 + q3 * q3)) * mx + 2.0 * (q1 * q2 - q0 * q3) * my
                  + 2.0 * (q1 * q3 + q0 * q2) * mz)
            hy = (2.0 * (q1 * q2 + q0 * q3) * mx + (1.0 - 2.0 * (q1 * q1 + q3 * q3)) * my
                  + 2.0 * (q2 * q3 - q0 * q1) * mz)
            hz = (2.0 * (q1 * q3 - q0 * q2) * mx + 2.0 * (q2 * q3 + q0 * q1) * my
                  + (1.0 - 2.0 * (q1 * q1 + q2 * q2)) * mz)
            bxy = math.sqrt(hx * hx + hy * hy)
            if frame == 0:  # ENU: north is y
                t0, t1, t2, t3 = _grad(q0, q1, q2, q3, 0.0, bxy, hz, mx, my, mz)
            else:  # NED, NWU: north is x
                t0, t1, t2, t3 = _grad(q0, q1, q2, q3, bxy, 0.0, hz, mx, my, mz)
            s0 += t0
            s1 += t1
            s2 += t2
            s3 += t3
        sn = math.sqrt(s0 * s0 + s1 * s1 + s2 * s2 + s3 * s3)
        if sn > 0.0:
            s0, s1, s2, s3 = s0 / sn, s1 / sn, s2 / sn, s3 / sn
        if marg:
            # eqs. 47-48: omega_eps = 2 q* (x) s, omega_b += zeta omega_eps dt; eq. 49: omega_c = omega - omega_b
            bx += 2.0 * (q0 * s1 - q1 * s0 - q2 * s3 + q3 * s2) * dt * zeta
            by += 2.0 * (q0 * s2 + q1 * s3 - q2 * s0 - q3 * s1) * dt * zeta
            bz += 2.0 * (q0 * s3 - q1 * s2 + q2 * s1 - q3 * s0) * dt * zeta
            gx, gy, gz = gx - bx, gy - by, gz - bz
        # eq. 12: q_dot_omega = 0.5 q (x) (0, omega); eqs. 42-43: minus beta s
        d0 = 0.5 * (-q1 * gx - q2 * gy - q3 * gz) - gain * s0
        d1 = 0.5 * (q0 * gx + q2 * gz - q3 * gy) - gain * s1
        d2 = 0.5 * (q0 * gy - q1 * gz + q3 * gx) - gain * s2
        d3 = 0.5 * (q0 * gz + q1 * gy - q2 * gx) - gain * s3
    else:  # no valid gravity: the gyroscope alone (uncompensated)
        d0 = 0.5 * (-q1 * gx - q2 * gy - q3 * gz)
        d1 = 0.5 * (q0 * gx + q2 * gz - q3 * gy)
        d2 = 0.5 * (q0 * gy - q1 * gz + q3 * gx)
        d3 = 0.5 * (q0 * gz + q1 * gy - q2 * gx)
    # eq. 13 and normalisation
    n0, n1, n2, n3 = q0 + d0 * dt, q1 + d1 * dt, q2 + d2 * dt, q3 + d3 * dt
    r = 1.0 / math.sqrt(n0 * n0 + n1 * n1 + n2 * n2 + n3 * n3)
    return n0 * r, n1 * r, n2 * r, n3 * r, bx, by, bz


@njit(cache=True)
def imu_tools_madgwick_kernel(gyr, acc, mag, coef, state, out, bias_out):
    """``imu_filter_madgwick`` over whole arrays.

    Parameters
    ----------
    gyr, acc, mag : (N, 3) float64
        rad/s, any unit (normalised), the field in any unit (bias subtracted, then normalised); ``mag`` (0, 3)
        for the IMU update.
    coef : (C.LEN,) float64
        Layout :data:`C`.
    state : (S.LEN,) float64
        Layout :data:`S`, read and written (streaming resumes from it).
    out : (N, 4) float64
        Written: the orientation after each sample (NaN while the start sample is degenerate).
    bias_out : (N, 3) or (0, 3) float64
        Written when not empty: omega_b after each sample.
    """
    dt, gain, zeta = coef[C.DT], coef[C.GAIN], coef[C.ZETA]
    frame = int(coef[C.FRAME])
    has_mag = coef[C.USE_MAG] != 0.0 and mag.shape[0] == gyr.shape[0]
    bmx, bmy, bmz = coef[C.MAG_BIAS], coef[C.MAG_BIAS + 1], coef[C.MAG_BIAS + 2]
    q0, q1, q2, q3 = state[S.Q], state[S.Q + 1], state[S.Q + 2], state[S.Q + 3]
    bx, by, bz = state[S.WB], state[S.WB + 1], state[S.WB + 2]
    phase = int(state[S.PHASE])
    for i in range(gyr.shape[0]):
        ax, ay, az = acc[i, 0], acc[i, 1], acc[i, 2]
        mx = my = mz = 0.0
        marg = False
        if has_mag:
            mx, my, mz = mag[i, 0] - bmx, mag[i, 1] - bmy, mag[i, 2] - bmz
            marg = (math.isfinite(mx) and math.isfinite(my) and math.isfinite(mz)
                    and not (mx == 0.0 and my == 0.0 and mz == 0.0))
        step = dt
        if phase == 2:  # a given start orientation: the start sample is still updated with dt = 0
            phase = 1
            step = 0.0
        elif phase == 0:
            if marg:
                ex, ey, ez = mx, my, mz
            elif abs(ax) > 0.1 or abs(ay) > 0.1:
                ex, ey, ez = ay, ax, 0.0
            elif abs(az) > 0.1:
                ex, ey, ez = 0.0, az, ay
            else:
                ex = ey = ez = 0.0
            ok, w, x, y, z = _stateless(frame, ax, ay, az, ex, ey, ez)
            if not ok:
                for k in range(4):
                    out[i, k] = np.nan
                if bias_out.shape[0] > 0:
                    bias_out[i, 0], bias_out[i, 1], bias_out[i, 2] = bx, by, bz
                continue
            q0, q1, q2, q3 = w, x, y, z
            phase = 1
            step = 0.0  # the start sample is updated with dt = 0 (its stamp is the last stamp)
        q0, q1, q2, q3, bx, by, bz = _update(q0, q1, q2, q3, bx, by, bz, gyr[i, 0], gyr[i, 1], gyr[i, 2], ax, ay,
                                             az, mx, my, mz, marg, step, gain, zeta, frame)
        out[i, 0], out[i, 1], out[i, 2], out[i, 3] = q0, q1, q2, q3
        if bias_out.shape[0] > 0:
            bias_out[i, 0], bias_out[i, 1], bias_out[i, 2] = bx, by, bz
    state[S.Q], state[S.Q + 1], state[S.Q + 2], state[S.Q + 3] = q0, q1, q2, q3
    state[S.WB], state[S.WB + 1], state[S.WB + 2] = bx, by, bz
    state[S.PHASE] = float(phase)


def coefficients(v: dict, dt: float, use_mag: bool) -> np.ndarray:
    """The coefficient array (layout :data:`C`) from validated values; the one place it is built."""
    return C.pack(DT=float(dt), GAIN=float(v["gain"]), ZETA=float(v["zeta"]), FRAME=float(FRAMES[v["world_frame"]]),
                  USE_MAG=1.0 if use_mag else 0.0,
                  MAG_BIAS=(float(v["mag_bias_x"]), float(v["mag_bias_y"]), float(v["mag_bias_z"])))


def initial_state(q0: np.ndarray | None) -> np.ndarray:
    """The start state (layout :data:`S`): ``q0`` (sensor-to-earth in the world frame) when given, else the
    node's own start from the first sample (``PHASE`` 0)."""
    st = np.zeros(S.LEN)
    if q0 is None:
        st[S.Q] = 1.0
    else:
        st[S.Q:S.Q + 4] = np.asarray(q0, float) / np.linalg.norm(q0)
        st[S.PHASE] = 2.0
    return st
