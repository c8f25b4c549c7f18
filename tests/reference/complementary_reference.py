"""Slow per-sample LCF/NCF/CCF (Narkhede et al. 2021) on ZYX Euler angles in NED, for tests.

Written from the paper's equations with rotation matrices instead of the kernel's closed forms:
the measurement roll/pitch/yaw are read from the TRIAD-like matrix built from the gravity and
tilt-compensated field (equivalent to eqs. 4-6), and the Euler rates use the inverse of the
ZYX kinematic matrix (eqs. 1-3).
"""

from __future__ import annotations

import numpy as np


def wrap(a):
    return (np.asarray(a) + np.pi) % (2 * np.pi) - np.pi


def rx(a):
    c, s = np.cos(a), np.sin(a)
    return np.array([[1, 0, 0], [0, c, -s], [0, s, c]])


def ry(a):
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])


def measured_angles(acc, mag, roll_pitch_fallback=None):
    """(roll, pitch, yaw or None) from one acc (specific force) and mag sample, NED."""
    d = -np.asarray(acc, float)
    roll = np.arctan2(d[1], d[2])
    pitch = np.arctan2(-d[0], np.hypot(d[1], d[2]))
    yaw = None
    if mag is not None and np.all(np.isfinite(mag)) and np.dot(mag, mag) > 0:
        # de-rotate roll and pitch: the field in a level frame that carries the heading only
        h = ry(pitch) @ rx(roll) @ np.asarray(mag, float)
        yaw = np.arctan2(-h[1], h[0])
    return roll, pitch, yaw


def complementary_ref(gyr, acc, mag, dt, euler0, alpha, kp, ki, static=False):
    """Euler estimates (N, 3). ``static``: eq. (14) as written, x_hat = alpha x + (1 - alpha) x_a with the
    integrator x driven by the gyro and the PI on x_a - x_hat (the blend is not fed back)."""
    x = np.array(euler0, float)
    integ = np.zeros(3)
    out = np.empty((len(gyr), 3))
    for i in range(len(gyr)):
        phi, th, _ = x
        T = np.array([[1, np.sin(phi) * np.tan(th), np.cos(phi) * np.tan(th)],
                      [0, np.cos(phi), -np.sin(phi)],
                      [0, np.sin(phi) / np.cos(th), np.cos(phi) / np.cos(th)]])
        rate = T @ gyr[i]
        a = acc[i]
        ok = np.all(np.isfinite(a)) and np.dot(a, a) > 0
        if ok:
            roll, pitch, yaw = measured_angles(a, None if mag is None else mag[i])
            xa = np.array([roll, pitch, x[2] if yaw is None else yaw])
            e = wrap(xa - x)
            if yaw is None:
                e[2] = 0.0
            if static:
                e = wrap(xa - (x + (1 - alpha) * e))  # x_a - x_hat, x_hat at the integrator's last value
            integ = integ + ki * e * dt
            rate = rate + kp * e
        rate = rate + integ
        pred = x + dt * rate
        if pred[1] > np.pi / 2:
            pred = np.array([pred[0] + np.pi, np.pi - pred[1], pred[2] + np.pi])
        elif pred[1] < -np.pi / 2:
            pred = np.array([pred[0] + np.pi, -np.pi - pred[1], pred[2] + np.pi])
        blend = np.zeros(3)
        if ok:
            blend = (1 - alpha) * wrap(xa - pred)
            if yaw is None:
                blend[2] = 0.0
        if static:
            x = np.array([wrap(pred[0]), pred[1], wrap(pred[2])])
            out[i] = np.array([wrap(pred[0] + blend[0]), pred[1] + blend[1], wrap(pred[2] + blend[2])])
        else:
            pred = pred + blend
            x = np.array([wrap(pred[0]), pred[1], wrap(pred[2])])
            out[i] = x
    return out
