"""Slow plain-NumPy QUKF / QRAUKF (Chiella et al. 2019), written from the equations, for tests.

Differs from the kernel in form only: general matrices (np.linalg.cholesky, inv), the quaternion
unscented transform of eqs. 9-15 evaluated literally for eq. 28 (12 sigma points over the 6-D
tangent state) instead of its closed form, the algebraic quaternion of eqs. 22-24 through rotation
matrices, and np.median for eq. 36.
"""

from __future__ import annotations

import numpy as np

Q_ENU_FROM_NWU = np.array([np.sqrt(0.5), 0.0, 0.0, np.sqrt(0.5)])


def qmul(p, q):
    """Hamilton product: [pw qw - pv.qv, pw qv + qw pv + pv x qv] (the cross product written out: np.cross
    costs ~20 us per call, three quarters of this reference's run time)."""
    pw, px, py, pz = p
    qw, qx, qy, qz = q
    return np.array([pw * qw - (px * qx + py * qy + pz * qz),
                     pw * qx + qw * px + (py * qz - pz * qy),
                     pw * qy + qw * py + (pz * qx - px * qz),
                     pw * qz + qw * pz + (px * qy - py * qx)])


def conj(q):
    return np.array([q[0], -q[1], -q[2], -q[3]])


def r2q(r):
    """Eq. 2."""
    th = np.linalg.norm(r)
    if th == 0:
        return np.array([1.0, 0.0, 0.0, 0.0])
    return np.concatenate([[np.cos(th / 2)], np.sin(th / 2) * r / th])


def q2r_acos(e):
    """Eq. 1 as printed (arccos): exact in theory, but arccos near 1 quantises angles below ~1e-7."""
    v, n = e[0], e[1:]
    nn = np.linalg.norm(n)
    if nn == 0:
        return np.zeros(3)
    if v >= 0:
        return 2 * np.arccos(min(v, 1.0)) * n / nn
    return -2 * np.arccos(min(-v, 1.0)) * n / nn


def q2r(e):
    """Eq. 1 with the half angle from arcsin(|n|) (small angles) or arccos(|v|) (large ones)."""
    v, n = e[0], e[1:]
    nn = np.linalg.norm(n)
    if nn == 0:
        return np.zeros(3)
    half = np.arcsin(min(nn, 1.0)) if nn < 0.7 else np.arccos(min(abs(v), 1.0))
    return (2 * half if v >= 0 else -2 * half) * n / nn


def qminus(a, b):
    """Eq. 3."""
    return q2r(qmul(a, conj(b)))


def qplus(e, r):
    """Eq. 4."""
    return qmul(r2q(r), e)


def wmean(E, w, start, tol=1e-12, iters=6):
    """Eq. 5 by the iterative (gradient-descent) mean."""
    m = start
    for _ in range(iters):
        d = sum(wj * qminus(e, m) for e, wj in zip(E, w))
        if np.linalg.norm(d) < tol:
            break
        m = qplus(m, d)
    return m


def wmean_eig(E, w):
    """Eq. 6: eigenvector of sum w e e^T with the largest eigenvalue."""
    M = sum(wj * np.outer(e, e) for e, wj in zip(E, w))
    vals, vecs = np.linalg.eigh(M)
    return vecs[:, -1]


def aqua_enu(a, b):
    """Eqs. 22-24 (Valenti's eq. 24), sensor-to-earth in ENU."""
    a = a / np.linalg.norm(a)
    b = b / np.linalg.norm(b)
    ax, ay, az = a
    if az >= 0:
        l1 = np.sqrt((az + 1) / 2)
        qa = np.array([l1, -ay / (2 * l1), ax / (2 * l1), 0.0])
    else:
        l2 = np.sqrt((1 - az) / 2)
        qa = np.array([-ay / (2 * l2), l2, 0.0, ax / (2 * l2)])
    l_vec = qmul(qmul(conj(qa), np.r_[0.0, b]), qa)[1:]
    lx, ly = l_vec[0], l_vec[1]
    G = lx * lx + ly * ly
    if lx >= 0:
        l3 = np.sqrt(G + lx * np.sqrt(G))
        qm = np.array([l3 / np.sqrt(2 * G), 0, 0, ly / (np.sqrt(2) * l3)])
    else:
        l4 = np.sqrt(G - lx * np.sqrt(G))
        qm = np.array([ly / (np.sqrt(2) * l4), 0, 0, l4 / np.sqrt(2 * G)])
    return qmul(Q_ENU_FROM_NWU, conj(qmul(qa, qm)))


def measurement_ut(a, b, sig_a, sig_b):
    """Eq. 25: UT of [a; b] with diag(R_a, R_b) through h_ab (raw a; mag noise relative to |b|)."""
    x = np.concatenate([a, b / np.linalg.norm(b)])
    S = np.diag(np.r_[[sig_a] * 3, [sig_b] * 3])
    n = 6
    pts = [x + np.sqrt(n) * S[:, i] for i in range(n)] + [x - np.sqrt(n) * S[:, i] for i in range(n)]
    w = np.full(2 * n, 1.0 / (2 * n))
    Y = [aqua_enu(p[:3], p[3:]) for p in pts]
    y = wmean(Y, w, aqua_enu(a, b))
    R = sum(wj * np.outer(qminus(Yj, y), qminus(Yj, y)) for Yj, wj in zip(Y, w))
    return y, R


def run_reference(gyr, acc, mag, dt, q0, *, sigma_gyr, att_rw, bias_rw, sigma_acc, sigma_mag,
                  p0_att=0.1, p0_bias=0.01, robust=False, window=20, n_sigma=3.0):
    n = len(gyr)
    e = np.asarray(q0, float)
    beta = np.zeros(3)
    P = np.diag([p0_att**2] * 3 + [p0_bias**2] * 3)
    Q1 = np.eye(3) * sigma_gyr**2
    Q2 = np.diag([att_rw**2 * dt] * 3 + [bias_rw**2 * dt] * 3)
    out = np.empty((n, 4))
    bias = np.empty((n, 3))
    innov = []
    for k in range(n):
        if k > 0:
            # eq. 26: UT over the augmented [x; q1] (9-D tangent space)
            Pa = np.zeros((9, 9))
            Pa[:6, :6] = P
            Pa[6:, 6:] = Q1
            L = np.linalg.cholesky(Pa)
            cols = [3.0 * L[:, i] for i in range(9)] + [-3.0 * L[:, i] for i in range(9)]
            w = np.full(18, 1.0 / 18)
            E, B = [], []
            for d in cols:
                ej = qplus(e, d[:3])
                bj = beta + d[3:6]
                u = gyr[k - 1] - bj - d[6:9]
                ang = np.linalg.norm(u) * dt
                # eq. 17: vec(e_k) = A vec(e_k-1), A = cos I + (T/2) sinc Omega
                Om = np.array([[0, -u[0], -u[1], -u[2]], [u[0], 0, u[2], -u[1]],
                               [u[1], -u[2], 0, u[0]], [u[2], u[1], -u[0], 0]])
                s = np.sin(ang / 2) / np.linalg.norm(u) if ang > 0 else dt / 2
                A = np.cos(ang / 2) * np.eye(4) + s * Om
                E.append(A @ ej)
                B.append(bj)
            start = qmul(e, r2q((gyr[k - 1] - beta) * dt))
            e = wmean(E, w, start)
            beta = sum(wj * bj for bj, wj in zip(B, w))
            Dv = [np.r_[qminus(Ej, e), Bj - beta] for Ej, Bj in zip(E, B)]
            P = sum(wj * np.outer(d, d) for d, wj in zip(Dv, w))
            P = P + Q2  # eq. 27
        y, R0 = measurement_ut(acc[k], mag[k], sigma_acc, sigma_mag)
        # eq. 28 literally: UT of h(x) = e over the 6-D state
        L = np.linalg.cholesky(P)
        cols = [np.sqrt(6) * L[:, i] for i in range(6)] + [-np.sqrt(6) * L[:, i] for i in range(6)]
        w = np.full(12, 1.0 / 12)
        X = [(qplus(e, d[:3]), beta + d[3:]) for d in cols]
        Y = [xe for xe, _ in X]
        yhat = wmean(Y, w, e)
        Pyy_t = sum(wj * np.outer(qminus(Yj, yhat), qminus(Yj, yhat)) for Yj, wj in zip(Y, w))
        Pxy = sum(wj * np.outer(np.r_[qminus(xe, e), xb - beta], qminus(Yj, yhat))
                  for (xe, xb), Yj, wj in zip(X, Y, w))
        v = qminus(y, yhat)  # eq. 30
        lam = np.ones(3)
        R = R0
        if robust:
            innov.append(v)
            Wn = np.array(innov[-window:])
            med = np.median(Wn, axis=0)
            s = 1.4826 * np.median(np.abs(Wn - med), axis=0)
            dev = np.abs(Wn - med)
            with np.errstate(divide="ignore", invalid="ignore"):
                lamW = np.where(dev > n_sigma * s, n_sigma * s / dev, 1.0)  # eq. 36
            LV = lamW * Wn
            Rh = np.maximum(LV.T @ LV / len(Wn) - Pyy_t, R0)  # eq. 37
            try:
                np.linalg.cholesky(Rh)
                R = Rh
            except np.linalg.LinAlgError:
                R = R0
            lam = lamW[-1]
        Pyy = Pyy_t + R  # eq. 29
        K = Pxy @ np.linalg.inv(Pyy)  # eq. 31
        c = K @ (lam * v)
        e = qplus(e, c[:3])  # eqs. 32 / 38
        beta = beta + c[3:]
        P = P - K @ Pyy @ K.T  # eq. 33
        P = 0.5 * (P + P.T)
        out[k] = e
        bias[k] = beta
    return out, bias
