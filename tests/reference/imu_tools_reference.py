"""Slow per-sample references of the two imu_tools filters, written from the papers' equations with quaternion
products (no matrices of the kernels, no shared code):

- :func:`madgwick_node`: Madgwick's 2010 report (eqs. 12-13, 20-21 as the product rule of ``q* d q``, 25-34,
  42-49) with the node's world frames, stateless start and MARG/IMU updates
  (:mod:`objectives.attitude.filters.imu_tools_madgwick`);
- :func:`valenti_node`: Valenti et al. 2015 (eqs. 25, 35-36, 38-61) with the node's steady-state bias estimate
  (:mod:`objectives.attitude.filters.valenti`).

Used by tests/attitude/test_imu_tools_filters.py to check the numba kernels (and through them the C ports).
"""

from __future__ import annotations

import math

import numpy as np
from scipy.spatial.transform import Rotation

E = np.eye(4)  # basis quaternions 1, i, j, k


def qmul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Hamilton product (w, x, y, z)."""
    w1, v1, w2, v2 = a[0], a[1:], b[0], b[1:]
    return np.concatenate([[w1 * w2 - v1 @ v2], w1 * v2 + w2 * v1 + np.cross(v1, v2)])


def conj(q: np.ndarray) -> np.ndarray:
    return q * np.array([1.0, -1.0, -1.0, -1.0])


def pure(v) -> np.ndarray:
    return np.concatenate([[0.0], np.asarray(v, float)])


def rot(q: np.ndarray, v) -> np.ndarray:
    """q (x) v (x) q*."""
    return qmul(qmul(q, pure(v)), conj(q))[1:]


# --- imu_filter_madgwick -----------------------------------------------------------------------------------
_FRAMES = {"enu": 0, "ned": 1, "nwu": 2}


def _f20(q: np.ndarray, d: np.ndarray, s: np.ndarray) -> np.ndarray:
    """The report's eq. 20: q* d q - s written with the unit norm used on the diagonal (1 - 2 q2^2 - 2 q3^2 ...),
    the form whose Jacobian is eq. 21."""
    w, x, y, z = q
    R = np.array([[1 - 2 * (y * y + z * z), 2 * (x * y + w * z), 2 * (x * z - w * y)],
                  [2 * (x * y - w * z), 1 - 2 * (x * x + z * z), 2 * (y * z + w * x)],
                  [2 * (x * z + w * y), 2 * (y * z - w * x), 1 - 2 * (x * x + y * y)]])
    return R @ d - s


def _grad(q: np.ndarray, d: np.ndarray, s: np.ndarray) -> np.ndarray:
    """J^T f of eqs. 20-21, J by complex-step differentiation of eq. 20 (exact for a polynomial)."""
    h = 1e-30
    J = np.column_stack([_f20(q + 1j * h * E[i], d, s).imag / h for i in range(4)])
    return J.T @ _f20(q, d, s)


def _stateless(frame: str, a: np.ndarray, e: np.ndarray) -> np.ndarray | None:
    h = np.cross(e, a)
    if np.linalg.norm(h) < 1e-7:
        return None
    h = h / np.linalg.norm(h)
    a = a / np.linalg.norm(a)
    m = np.cross(a, h)
    rows = {"enu": (h, m, a), "ned": (m, h, -a), "nwu": (m, -h, a)}[frame]
    x, y, z, w = Rotation.from_matrix(np.vstack(rows)).as_quat()
    return np.array([w, x, y, z])


def madgwick_node(values: dict, gyr, acc, mag, dt: float, q_start=None) -> tuple[np.ndarray, np.ndarray]:
    """(quat (N, 4) sensor-to-earth in ``world_frame``, omega_b (N, 3)) of the node's filter; ``q_start`` a given
    start orientation instead of the stateless one."""
    frame = values["world_frame"]
    up = np.array([0.0, 0.0, -1.0 if frame == "ned" else 1.0])
    bias_m = np.array([values["mag_bias_x"], values["mag_bias_y"], values["mag_bias_z"]], float)
    use_mag = values["use_mag"] and mag is not None
    q, wb, started = None, np.zeros(3), False
    out, bout = np.full((len(gyr), 4), np.nan), np.zeros((len(gyr), 3))
    for i in range(len(gyr)):
        g, a = np.array(gyr[i], float), np.array(acc[i], float)
        m = np.array(mag[i], float) - bias_m if use_mag else None
        marg = m is not None and np.isfinite(m).all() and np.any(m != 0)
        step = dt
        if not started:
            if q_start is not None:
                q = np.asarray(q_start, float) / np.linalg.norm(q_start)
            else:
                if marg:
                    e = m
                elif abs(a[0]) > 0.1 or abs(a[1]) > 0.1:
                    e = np.array([a[1], a[0], 0.0])
                else:
                    e = np.array([0.0, a[2], a[1]])
                q = _stateless(frame, a, e)
                if q is None:
                    bout[i] = wb
                    continue
            started, step = True, 0.0
        if np.any(a != 0):
            an = a / np.linalg.norm(a)
            s = _grad(q, up, an)
            if marg:
                mn = m / np.linalg.norm(m)
                h = rot(q, mn)
                bxy = math.hypot(h[0], h[1])
                b = np.array([0.0, bxy, h[2]]) if frame == "enu" else np.array([bxy, 0.0, h[2]])
                s = s + _grad(q, b, mn)
            if np.linalg.norm(s) > 0:
                s = s / np.linalg.norm(s)
            if marg:
                wb = wb + 2.0 * qmul(conj(q), s)[1:] * step * values["zeta"]
                g = g - wb
            qdot = 0.5 * qmul(q, pure(g)) - values["gain"] * s
        else:
            qdot = 0.5 * qmul(q, pure(g))
        q = q + qdot * step
        q = q / np.linalg.norm(q)
        out[i], bout[i] = q, wb
    return out, bout


# --- imu_complementary_filter (Valenti et al. 2015) --------------------------------------------------------
def _q_acc(a: np.ndarray) -> np.ndarray:
    ax, ay, az = a / np.linalg.norm(a)
    if az >= 0:  # eq. 25
        return np.array([math.sqrt((az + 1) / 2), -ay / math.sqrt(2 * (az + 1)), ax / math.sqrt(2 * (az + 1)), 0.0])
    return np.array([-ay / math.sqrt(2 * (1 - az)), math.sqrt((1 - az) / 2), 0.0, ax / math.sqrt(2 * (1 - az))])


def _q_mag(lx: float, ly: float) -> np.ndarray:
    gam = lx * lx + ly * ly
    if lx >= 0:  # eq. 35
        return np.array([math.sqrt(gam + lx * math.sqrt(gam)) / math.sqrt(2 * gam), 0.0, 0.0,
                         ly / (math.sqrt(2) * math.sqrt(gam + lx * math.sqrt(gam)))])
    return np.array([ly / (math.sqrt(2) * math.sqrt(gam - lx * math.sqrt(gam))), 0.0, 0.0,
                     math.sqrt(gam - lx * math.sqrt(gam)) / math.sqrt(2 * gam)])


def _fraction(dq: np.ndarray, gain: float) -> np.ndarray:
    """Eqs. 48-52: LERP above 0.9, SLERP below, from the identity."""
    ident = np.array([1.0, 0.0, 0.0, 0.0])
    if dq[0] > 0.9:
        r = (1 - gain) * ident + gain * dq
    else:
        om = math.acos(dq[0])
        r = math.sin((1 - gain) * om) / math.sin(om) * ident + math.sin(gain * om) / math.sin(om) * dq
    return r / np.linalg.norm(r)


def adaptive_factor(e: float) -> float:
    """Eq. 61 with t1 = 0.1, t2 = 0.2."""
    return float(np.interp(e, [0.1, 0.2], [1.0, 0.0]))


def valenti_node(values: dict, gyr, acc, mag, dt: float, g: float = 9.81, q_start=None):
    """(quat (N, 4) sensor-to-earth in NWU, bias (N, 3)) of the node's filter."""
    use_mag = values["use_mag"] and mag is not None
    q, b, prev, started = None, np.zeros(3), np.zeros(3), False
    out, bout = np.empty((len(gyr), 4)), np.empty((len(gyr), 3))
    for i in range(len(gyr)):
        w, a = np.array(gyr[i], float), np.array(acc[i], float)
        m = np.array(mag[i], float) if use_mag else None
        if not started:
            if q_start is not None:
                q = conj(np.asarray(q_start, float) / np.linalg.norm(q_start))
            else:
                q = _q_acc(a)
                if use_mag:
                    l = qmul(qmul(conj(q), pure(m)), q)[1:]  # eq. 26: into the tilt-free frame
                    q = qmul(q, _q_mag(l[0], l[1]))  # eq. 36
            started = True
        else:
            an = np.linalg.norm(a)
            if values["do_bias_estimation"]:
                steady = (abs(an - g) <= 0.1 * g / 9.81 and np.all(np.abs(w - prev) <= 0.01)
                          and np.all(np.abs(w - b) <= 0.2))
                if steady:
                    b = b + values["bias_alpha"] * (w - b)
                prev = w
            qw = q + (-0.5 * qmul(pure(w - b), q)) * dt  # eqs. 38-42
            qw = qw / np.linalg.norm(qw)
            gp = qmul(qmul(conj(qw), pure(a / an)), qw)[1:]  # eq. 44: the predicted gravity, global frame
            dq = np.array([math.sqrt((gp[2] + 1) / 2), -gp[1] / math.sqrt(2 * (gp[2] + 1)),
                           gp[0] / math.sqrt(2 * (gp[2] + 1)), 0.0])  # eq. 47
            alpha = values["gain_acc"] * (adaptive_factor(abs(an - g) / g) if values["do_adaptive_gain"] else 1.0)
            q = qmul(qw, _fraction(dq, alpha))  # eq. 53
            if use_mag:
                l = qmul(qmul(conj(q), pure(m)), q)[1:]  # eq. 54
                gam = l[0] ** 2 + l[1] ** 2
                dm = np.array([math.sqrt(gam + l[0] * math.sqrt(gam)) / math.sqrt(2 * gam), 0.0, 0.0,
                               l[1] / (math.sqrt(2) * math.sqrt(gam + l[0] * math.sqrt(gam)))])  # eq. 58
                q = qmul(q, _fraction(dm, values["gain_mag"]))  # eq. 59
            q = q / np.linalg.norm(q)
        out[i], bout[i] = conj(q), b
    return out, bout
