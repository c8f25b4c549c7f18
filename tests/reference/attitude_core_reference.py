"""Slow references for the quaternion kernels and attitude metrics, in plain Python/NumPy.

Written from the definitions, not from the kernels: rotation by the quaternion sandwich product,
Euler angles by composing elementary rotations, TRIAD literally as the FAEKF paper's eqs. 11-14
(gravity pointing down in NED, eq. 13 as the earth-to-sensor matrix, eq. 14 as printed), and the
metrics by per-sample loops.
"""

from __future__ import annotations

import math

import numpy as np


def hamilton(p, q):
    """Hamilton product from the quaternion algebra i^2 = j^2 = k^2 = ijk = -1."""
    a1, b1, c1, d1 = p
    a2, b2, c2, d2 = q
    return np.array([
        a1 * a2 - b1 * b2 - c1 * c2 - d1 * d2,
        a1 * b2 + b1 * a2 + c1 * d2 - d1 * c2,
        a1 * c2 - b1 * d2 + c1 * a2 + d1 * b2,
        a1 * d2 + b1 * c2 - c1 * b2 + d1 * a2,
    ])


def conj(q):
    return np.array([q[0], -q[1], -q[2], -q[3]])


def rotate(q, v):
    """``q * (0, v) * conj(q)`` (FAEKF eq. 2)."""
    return hamilton(hamilton(q, np.r_[0.0, v]), conj(q))[1:]


def matrix(q):
    """Columns are the rotated basis vectors."""
    return np.column_stack([rotate(q, e) for e in np.eye(3)])


def elementary(axis: int, angle: float) -> np.ndarray:
    c, s = math.cos(angle), math.sin(angle)
    if axis == 0:
        return np.array([[1, 0, 0], [0, c, -s], [0, s, c]])
    if axis == 1:
        return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])


def matrix_from_euler(roll, pitch, yaw):
    """``Rz(yaw) Ry(pitch) Rx(roll)``: the intrinsic z-y'-x'' sequence."""
    return elementary(2, yaw) @ elementary(1, pitch) @ elementary(0, roll)


def euler_eq6(q):
    """The FAEKF paper's eq. 6 exactly as printed (q0 = w)."""
    q0, q1, q2, q3 = q
    phi = math.atan2(2 * q2 * q3 - 2 * q0 * q1, 2 * q0 ** 2 + 2 * q3 ** 2 - 1)
    x = 2 * q0 * q2 + 2 * q1 * q3
    theta = -math.atan(x / math.sqrt(1 - x * x))
    psi = math.atan2(2 * q1 * q2 - 2 * q0 * q3, 2 * q0 ** 2 + 2 * q1 ** 2 - 1)
    return np.array([phi, theta, psi])


def triad_paper_ned(acc_up, mag):
    """TRIAD literally as eqs. 11-14 in NED with the paper's references.

    The paper's accelerometer reads gravity ``g = (0, 0, 9.81)`` (down); ours reads the specific
    force (up), so ``A = -acc_up``. ``h = (b cos s, 0, b sin s)``. Eq. 13 gives the earth-to-sensor
    matrix ``S_R``; eq. 14 (valid for q0 well above 0) turns it into the returned quaternion.
    """
    g = np.array([0.0, 0.0, 9.81])
    h = np.array([math.cos(1.1), 0.0, math.sin(1.1)]) * 48.0
    A = -np.asarray(acc_up, float)
    H = np.asarray(mag, float)
    s1 = g / np.linalg.norm(g)
    s2 = np.cross(g, h) / np.linalg.norm(np.cross(g, h))
    s3 = np.cross(s1, s2)
    r1 = A / np.linalg.norm(A)
    r2 = np.cross(A, H) / np.linalg.norm(np.cross(A, H))
    r3 = np.cross(r1, r2)
    M_mea = np.column_stack([r1, r2, r3])
    M_ref = np.column_stack([s1, s2, s3])
    r = M_mea @ M_ref.T
    q0 = 0.5 * math.sqrt(1 + r[0, 0] + r[1, 1] + r[2, 2])
    return np.array([q0, (r[1, 2] - r[2, 1]) / (4 * q0), (r[2, 0] - r[0, 2]) / (4 * q0),
                     (r[0, 1] - r[1, 0]) / (4 * q0)])


def broad_rmse_loop(q_est, q_true, motion):
    """BROAD's total/heading/inclination RMSE (deg) by a loop over samples (example code formulas)."""
    tot, head, inc = [], [], []
    for qe, qt, m in zip(q_est, q_true, motion):
        if not m or not np.all(np.isfinite(qt)):
            continue
        if not np.all(np.isfinite(qe)):
            tot.append(math.pi), head.append(math.pi), inc.append(math.pi)
            continue
        qe = qe / np.linalg.norm(qe)
        qt = qt / np.linalg.norm(qt)
        d = hamilton(qe, conj(qt))
        d = d / np.linalg.norm(d)
        tot.append(2 * math.acos(min(abs(d[0]), 1.0)))
        head.append(2 * math.atan(abs(d[3] / d[0])) if d[0] != 0 else math.pi)
        inc.append(2 * math.acos(min(math.sqrt(d[0] ** 2 + d[3] ** 2), 1.0)))
    return tuple(math.degrees(math.sqrt(sum(x * x for x in a) / len(a))) for a in (tot, head, inc))
