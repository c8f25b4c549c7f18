"""Slow plain-NumPy Madgwick and Mahony filters written from the papers' matrix forms.

Madgwick 2010 report: objective ``f = [R^T g_e - a; R^T b_e - m]`` (eqs. 25, 29), gradient
``J^T f`` with the Jacobian obtained here by central finite differences of ``f`` (not the
hand-expanded Jacobian of the kernel), ``q_dot = 0.5 q (x) w - beta grad/|grad|`` (eq. 43), bias
drift eqs. 47-49. Mahony et al. 2008: ``w_mes = a x v_hat + m x w_hat``, PI on ``w_mes``.
Quaternions sensor-to-earth (w, x, y, z), NWU; one Python iteration per sample.
"""

from __future__ import annotations

import numpy as np


def qmul(p, q):
    w1, x1, y1, z1 = p
    w2, x2, y2, z2 = q
    return np.array([w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2, w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
                     w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2, w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2])


def rotmat(q):
    """Sensor-to-earth rotation matrix in the form the report's objective functions use
    (diagonal ``1 - 2(...)``, eqs. 25 and 29); for a unit ``q`` it is the rotation matrix, and its
    derivative at non-unit ``q`` is the report's Jacobian (eqs. 26 and 30)."""
    w, x, y, z = q
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
        [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
        [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
    ])


def _ok(v):
    return np.all(np.isfinite(v)) and np.dot(v, v) > 0


def madgwick_ref(gyr, acc, mag, dt, q0, beta, zeta=0.0, field_scale=1.0):
    """``field_scale`` multiplies the earth-field reference (1: paper, 0.5: the 2010 C code)."""
    q = np.array(q0, float) / np.linalg.norm(q0)
    bias = np.zeros(3)
    out = np.empty((len(gyr), 4))
    for i in range(len(gyr)):
        w = gyr[i] if np.all(np.isfinite(gyr[i])) else np.zeros(3)
        w = w - bias
        qdot = 0.5 * qmul(q, np.r_[0.0, w])
        a = acc[i]
        if _ok(a):
            a = a / np.linalg.norm(a)
            refs = [(np.array([0.0, 0.0, 1.0]), a)]
            m = None if mag is None else mag[i]
            if m is not None and _ok(m):
                m = m / np.linalg.norm(m)
                h = rotmat(q) @ m
                b = field_scale * np.array([np.hypot(h[0], h[1]), 0.0, h[2]])
                refs.append((b, m))

            def f(qq, refs=refs):
                return np.concatenate([rotmat(qq).T @ e - s for e, s in refs])

            J = np.empty((3 * len(refs), 4))
            eps = 1e-7
            for j in range(4):
                d = np.zeros(4)
                d[j] = eps
                J[:, j] = (f(q + d) - f(q - d)) / (2 * eps)
            grad = J.T @ f(q)
            n = np.linalg.norm(grad)
            if n > 0:
                s = grad / n
                qdot = qdot - beta * s
                if zeta:
                    bias = bias + zeta * dt * 2 * qmul(q * [1, -1, -1, -1], s)[1:]
        q = q + qdot * dt
        q /= np.linalg.norm(q)
        out[i] = q
    return out


def mahony_ref(gyr, acc, mag, dt, q0, kp, ki):
    q = np.array(q0, float) / np.linalg.norm(q0)
    integral = np.zeros(3)
    out = np.empty((len(gyr), 4))
    for i in range(len(gyr)):
        w = gyr[i] if np.all(np.isfinite(gyr[i])) else np.zeros(3)
        a = acc[i]
        if _ok(a):
            R = rotmat(q)
            a = a / np.linalg.norm(a)
            e = np.cross(a, R.T @ [0.0, 0.0, 1.0])
            m = None if mag is None else mag[i]
            if m is not None and _ok(m):
                m = m / np.linalg.norm(m)
                h = R @ m
                e = e + np.cross(m, R.T @ [np.hypot(h[0], h[1]), 0.0, h[2]])
            integral = integral + ki * e * dt if ki > 0 else np.zeros(3)
            w = w + kp * e
        w = w + integral
        q = q + 0.5 * qmul(q, np.r_[0.0, w]) * dt
        q /= np.linalg.norm(q)
        out[i] = q
    return out
