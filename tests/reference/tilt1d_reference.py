"""Slow references for objectives.attitude.filters.kf1d and objectives.attitude.disturbance.

Written from the sources, independently of the kernels: the thesis's KF with 2x2 NumPy matrices
(eqs. 3.9-3.13), Madgwick's and Mahony's 3-D IMU sample code (MadgwickAHRSupdateIMU,
MahonyAHRSupdateIMU, transcribed line by line in Python), and eqs. 3.19-3.22 evaluated literally.
"""

from __future__ import annotations

import math

import numpy as np


def kf1d_ref(gyr_y, theta_a, dt, q00, q11, rho, theta0=0.0, P0=None, kscale=None):
    Phi = np.array([[1.0, -dt], [0.0, 1.0]])
    Gam = np.array([dt, 0.0])
    H = np.array([[1.0, 0.0]])
    Q = np.diag([q00, q11])
    x = np.array([theta0, 0.0])
    P = np.zeros((2, 2)) if P0 is None else np.array(P0, float)
    out = [x[0]]
    for k in range(1, len(gyr_y)):
        x = Phi @ x + Gam * gyr_y[k - 1]
        P = Phi @ P @ Phi.T + Q
        R = rho * (1.0 if kscale is None else kscale[k])
        G = P @ H.T @ np.linalg.inv(H @ P @ H.T + R)
        x = x + (G * (theta_a[k] - H @ x)).ravel()
        P = (np.eye(2) - G @ H) @ P
        out.append(x[0])
    return np.array(out)


def madgwick_imu_ref(gyr, acc, beta, dt, q):
    """MadgwickAHRSupdateIMU over (N, 3) arrays; returns (N, 4) with q[0] the initial state."""
    q0, q1, q2, q3 = q
    out = [(q0, q1, q2, q3)]
    for (gx, gy, gz), (ax, ay, az) in zip(gyr[:-1], acc[:-1]):
        qDot1 = 0.5 * (-q1 * gx - q2 * gy - q3 * gz)
        qDot2 = 0.5 * (q0 * gx + q2 * gz - q3 * gy)
        qDot3 = 0.5 * (q0 * gy - q1 * gz + q3 * gx)
        qDot4 = 0.5 * (q0 * gz + q1 * gy - q2 * gx)
        if not (ax == 0.0 and ay == 0.0 and az == 0.0):
            r = 1.0 / math.sqrt(ax * ax + ay * ay + az * az)
            ax, ay, az = ax * r, ay * r, az * r
            _2q0, _2q1, _2q2, _2q3 = 2 * q0, 2 * q1, 2 * q2, 2 * q3
            _4q0, _4q1, _4q2 = 4 * q0, 4 * q1, 4 * q2
            _8q1, _8q2 = 8 * q1, 8 * q2
            q0q0, q1q1, q2q2, q3q3 = q0 * q0, q1 * q1, q2 * q2, q3 * q3
            s0 = _4q0 * q2q2 + _2q2 * ax + _4q0 * q1q1 - _2q1 * ay
            s1 = (_4q1 * q3q3 - _2q3 * ax + 4.0 * q0q0 * q1 - _2q0 * ay - _4q1 + _8q1 * q1q1
                  + _8q1 * q2q2 + _4q1 * az)
            s2 = (4.0 * q0q0 * q2 + _2q0 * ax + _4q2 * q3q3 - _2q3 * ay - _4q2 + _8q2 * q1q1
                  + _8q2 * q2q2 + _4q2 * az)
            s3 = 4.0 * q1q1 * q3 - _2q1 * ax + 4.0 * q2q2 * q3 - _2q2 * ay
            r = 1.0 / math.sqrt(s0 * s0 + s1 * s1 + s2 * s2 + s3 * s3)
            qDot1 -= beta * s0 * r
            qDot2 -= beta * s1 * r
            qDot3 -= beta * s2 * r
            qDot4 -= beta * s3 * r
        q0, q1, q2, q3 = q0 + qDot1 * dt, q1 + qDot2 * dt, q2 + qDot3 * dt, q3 + qDot4 * dt
        r = 1.0 / math.sqrt(q0 * q0 + q1 * q1 + q2 * q2 + q3 * q3)
        q0, q1, q2, q3 = q0 * r, q1 * r, q2 * r, q3 * r
        out.append((q0, q1, q2, q3))
    return np.array(out)


def mahony_imu_ref(gyr, acc, kp, ki, dt, q):
    """MahonyAHRSupdateIMU (twoKp = 2 kp, twoKi = 2 ki) over (N, 3) arrays; (N, 4) output."""
    q0, q1, q2, q3 = q
    twoKp, twoKi = 2 * kp, 2 * ki
    ix = iy = iz = 0.0
    out = [(q0, q1, q2, q3)]
    for (gx, gy, gz), (ax, ay, az) in zip(gyr[:-1], acc[:-1]):
        if not (ax == 0.0 and ay == 0.0 and az == 0.0):
            r = 1.0 / math.sqrt(ax * ax + ay * ay + az * az)
            ax, ay, az = ax * r, ay * r, az * r
            hvx = q1 * q3 - q0 * q2
            hvy = q0 * q1 + q2 * q3
            hvz = q0 * q0 - 0.5 + q3 * q3
            hex_ = ay * hvz - az * hvy
            hey = az * hvx - ax * hvz
            hez = ax * hvy - ay * hvx
            if twoKi > 0.0:
                ix += twoKi * hex_ * dt
                iy += twoKi * hey * dt
                iz += twoKi * hez * dt
                gx, gy, gz = gx + ix, gy + iy, gz + iz
            else:
                ix = iy = iz = 0.0
            gx, gy, gz = gx + twoKp * hex_, gy + twoKp * hey, gz + twoKp * hez
        gx, gy, gz = gx * 0.5 * dt, gy * 0.5 * dt, gz * 0.5 * dt
        qa, qb, qc = q0, q1, q2
        q0 = q0 + (-qb * gx - qc * gy - q3 * gz)
        q1 = q1 + (qa * gx + qc * gz - q3 * gy)
        q2 = q2 + (qa * gy - qb * gz + q3 * gx)
        q3 = q3 + (qa * gz + qb * gy - qc * gx)
        r = 1.0 / math.sqrt(q0 * q0 + q1 * q1 + q2 * q2 + q3 * q3)
        q0, q1, q2, q3 = q0 * r, q1 * r, q2 * r, q3 * r
        out.append((q0, q1, q2, q3))
    return np.array(out)


def vibration_ref(x, dt, L, L_fft, omega_thr, f_thr):
    """Eqs. 3.19-3.21 literally per packet (direct DFT sum); causal hold, 0 over the first packet."""
    n = len(x)
    out = np.zeros(n)
    fs = 1.0 / dt
    for p in range(n // L):
        pk = np.zeros(L_fft)
        pk[:L] = x[p * L:(p + 1) * L]
        best_a, best_f = -1.0, 0.0
        for i in range(L_fft // 2 + 1):
            f = fs * i / L_fft
            if f > f_thr:
                break
            W = sum(pk[k] * np.exp(-2j * np.pi * i * k / L_fft) for k in range(L))
            a = 2.0 / L * abs(W)
            if a > best_a:
                best_a, best_f = a, f
        est = 0.0 if best_a < omega_thr else best_f
        out[(p + 1) * L:(p + 2) * L] = est
    return out


def packet_mean_ref(x, L):
    """Causal packet means: packet p's mean over packet p+1's samples (and a trailing partial)."""
    n = len(x)
    out = np.zeros(n)
    n_p = n // L
    for p in range(n_p):
        m = float(np.mean(x[p * L:(p + 1) * L]))
        stop = (p + 2) * L if p + 1 < n_p else n
        out[(p + 1) * L:stop] = m
    return out
