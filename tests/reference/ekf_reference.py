"""Slow reference of the quaternion EKF / FAEKF (FAEKF paper eqs. 11-22, 28-31, 36).

Plain NumPy, written from the equations with full matrices (``@``, ``np.linalg.inv``) and no
structure exploited, to check the numba kernel of :mod:`objectives.attitude.filters.ekf`.
Same conventions as the kernel (NED, sensor-to-earth, see that module's docstring).
"""

from __future__ import annotations

import math

import numpy as np


def triad_rotation_ned(acc: np.ndarray, mag: np.ndarray) -> np.ndarray:
    """Sensor-to-earth rotation matrix from one acc/mag pair, eqs. 11-13 with M_ref, M_mea."""
    up_e = np.array([0.0, 0.0, -1.0])       # direction of the specific force at rest, NED
    north_e = np.array([1.0, 0.0, 0.0])     # horizontal direction of the earth field
    s1 = up_e
    s2 = np.cross(up_e, north_e)
    s2 /= np.linalg.norm(s2)
    s3 = np.cross(s1, s2)
    r1 = acc / np.linalg.norm(acc)
    r2 = np.cross(acc, mag)
    r2 /= np.linalg.norm(r2)
    r3 = np.cross(r1, r2)
    m_mea = np.column_stack([r1, r2, r3])
    m_ref = np.column_stack([s1, s2, s3])
    return m_ref @ m_mea.T   # v_earth = R v_sensor


def quat_from_matrix(R: np.ndarray) -> np.ndarray:
    """Eq. 14 generalised: the unit quaternion whose eq.-3 matrix is ``R`` (largest pivot)."""
    w = 0.5 * math.sqrt(max(0.0, 1 + R[0, 0] + R[1, 1] + R[2, 2]))
    x = 0.5 * math.sqrt(max(0.0, 1 + R[0, 0] - R[1, 1] - R[2, 2]))
    y = 0.5 * math.sqrt(max(0.0, 1 - R[0, 0] + R[1, 1] - R[2, 2]))
    z = 0.5 * math.sqrt(max(0.0, 1 - R[0, 0] - R[1, 1] + R[2, 2]))
    i = int(np.argmax([w, x, y, z]))
    if i == 0:
        q = [w, (R[2, 1] - R[1, 2]) / (4 * w), (R[0, 2] - R[2, 0]) / (4 * w), (R[1, 0] - R[0, 1]) / (4 * w)]
    elif i == 1:
        q = [(R[2, 1] - R[1, 2]) / (4 * x), x, (R[0, 1] + R[1, 0]) / (4 * x), (R[0, 2] + R[2, 0]) / (4 * x)]
    elif i == 2:
        q = [(R[0, 2] - R[2, 0]) / (4 * y), (R[0, 1] + R[1, 0]) / (4 * y), y, (R[1, 2] + R[2, 1]) / (4 * y)]
    else:
        q = [(R[1, 0] - R[0, 1]) / (4 * z), (R[0, 2] + R[2, 0]) / (4 * z), (R[1, 2] + R[2, 1]) / (4 * z), z]
    q = np.array(q)
    return q / np.linalg.norm(q)


def rotmat(q: np.ndarray) -> np.ndarray:
    """Eq. 3."""
    q0, q1, q2, q3 = q / np.linalg.norm(q)
    v = np.array([q1, q2, q3])
    skew = np.array([[0, -q3, q2], [q3, 0, -q1], [-q2, q1, 0]])
    return (q0 * q0 - v @ v) * np.eye(3) + 2 * np.outer(v, v) + 2 * q0 * skew


def f_state(x: np.ndarray, gyr: np.ndarray, ts: float) -> np.ndarray:
    """Eq. 16 without noise, written out component by component as in the paper."""
    q0, q1, q2, q3, bx, by, bz = x
    ox, oy, oz = gyr
    h = ts / 2
    return np.array([
        q0 + h * (q1 * (bx - ox) + q2 * (by - oy) + q3 * (bz - oz)),
        q1 - h * (q0 * (bx - ox) - q3 * (by - oy) + q2 * (bz - oz)),
        q2 - h * (q3 * (bx - ox) + q0 * (by - oy) - q1 * (bz - oz)),
        q3 + h * (q2 * (bx - ox) - q1 * (by - oy) - q0 * (bz - oz)),
        bx, by, bz,
    ])


def jacobian(x: np.ndarray, gyr: np.ndarray, ts: float, eps: float = 1e-6) -> np.ndarray:
    """Phi of eq. 20 by central differences of eq. 16 (exact: f is bilinear in q and b)."""
    J = np.empty((7, 7))
    for j in range(7):
        d = np.zeros(7)
        d[j] = eps
        J[:, j] = (f_state(x + d, gyr, ts) - f_state(x - d, gyr, ts)) / (2 * eps)
    return J


def qmul(p: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Hamilton product via the left-multiplication matrix (eq. 5's Q(p) applied to q)."""
    p0, p1, p2, p3 = p
    Qp = np.array([[p0, -p1, -p2, -p3], [p1, p0, -p3, p2], [p2, p3, p0, -p1], [p3, -p2, p1, p0]])
    return Qp @ q


def f_exact(x: np.ndarray, gyr: np.ndarray, ts: float) -> np.ndarray:
    """Exact step q (x) exp((Omega - b) Ts / 2); bias constant."""
    w = gyr - x[4:]
    th = np.linalg.norm(w) * ts
    dq = np.concatenate([[math.cos(th / 2)], (math.sin(th / 2) / np.linalg.norm(w)) * w]) if th > 0 else \
        np.array([1.0, 0.0, 0.0, 0.0])
    return np.concatenate([qmul(x[:4], dq), x[4:]])


def ekf_reference(gyr, acc, mag, dt, q_q, q_w, rho, q0, p0_q=1e-2, p0_b=1e-6, kscale=None, use_mag=True,
                  integration="exact"):
    """Run the EKF (eqs. 16-22, 36) with R_k = K_k rho I4; returns (quat (N, 4), bias (N, 3)).

    ``integration="euler"`` is eq. 16; ``"exact"`` replaces the quaternion step by the exponential
    map and the quaternion block of Phi by its derivative (the bias columns stay those of eq. 21).
    """
    n = gyr.shape[0]
    x = np.concatenate([np.asarray(q0, float) / np.linalg.norm(q0), np.zeros(3)])
    P = np.diag([p0_q] * 4 + [p0_b] * 3)
    Q = np.diag([q_q] * 4 + [q_w] * 3)
    H = np.hstack([np.eye(4), np.zeros((4, 3))])
    out_q = np.empty((n, 4))
    out_b = np.empty((n, 3))
    out_q[0], out_b[0] = x[:4], x[4:]
    for k in range(1, n):
        Phi = jacobian(x, gyr[k - 1], dt)
        if integration == "exact":
            for j in range(4):  # linear in q: central differences are exact up to rounding
                d = np.zeros(7)
                d[j] = 1e-6
                Phi[:4, j] = (f_exact(x + d, gyr[k - 1], dt)[:4] - f_exact(x - d, gyr[k - 1], dt)[:4]) / 2e-6
            x = f_exact(x, gyr[k - 1], dt)
        else:
            x = f_state(x, gyr[k - 1], dt)
        P = Phi @ P @ Phi.T + Q
        m = mag[k] if use_mag else rotmat(x[:4]).T @ np.array([1.0, 0.0, 0.0])
        z = quat_from_matrix(triad_rotation_ned(acc[k], m))
        if z @ x[:4] < 0:
            z = -z
        R = np.eye(4) * rho * (1.0 if kscale is None else kscale[k])
        G = P @ H.T @ np.linalg.inv(H @ P @ H.T + R)
        x = x + G @ (z - H @ x)
        P = (np.eye(7) - G @ H) @ P
        x[:4] /= np.linalg.norm(x[:4])
        out_q[k], out_b[k] = x[:4], x[4:]
    return out_q, out_b


def fuzzy_scale_reference(vib, acc, mag, mf, kappa):
    """Eqs. 28-31 and Table 1 rule by rule: mf[input, set] = (mean, std), kappa = K1..K7."""
    table = {}
    for i_f in range(3):
        for i_a in range(3):
            for i_h in range(3):
                table[(i_f, i_a, i_h)] = i_f + i_a + i_h  # Table 1: K_{1 + i_f + i_a + i_h}
    out = np.empty(len(vib))
    for k in range(len(vib)):
        chi = (vib[k], acc[k], mag[k])
        num = den = 0.0
        for sets, kidx in table.items():
            gam = min(math.exp(-((chi[j] - mf[j, s, 0]) ** 2) / (2 * mf[j, s, 1] ** 2))
                      for j, s in enumerate(sets))
            num += kappa[kidx] * gam
            den += gam
        out[k] = num / den
    return out
