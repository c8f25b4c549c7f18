"""Slow pure-NumPy reference of the WMP model, derived from the Lagrangian (thesis eqs. 2.1-2.10).

Independent of the appendix formulas used in the kernel: the kinetic energy is written from the
coordinates of eqs. 2.1-2.3 and 2.5-2.6, the mass matrix is its Hessian in the velocities (exact by
polarisation, K being quadratic), and the Coriolis/centrifugal terms come from a central difference
of M(theta3): V = (dM/dtheta3 * dtheta3) qdot - e3 (1/2) qdot^T dM/dtheta3 qdot + dP/dq.
"""

from __future__ import annotations

import numpy as np


def kinetic_energy(th3, qd, p):
    """K of eqs. 2.5-2.6 (psi = 0 without loss of generality: K does not depend on psi)."""
    w1, w2, w3 = qd
    r, d, l = p.r_m, p.d_m, p.l_m
    sd = r * (w1 + w2) / 2
    psid = r * (w2 - w1) / d
    # wheel centres: speed of wheel i is r * w_i (eq. 2.2 differentiated, psi = 0)
    kw = sum(
        0.5 * p.m_w_kg * (r * w) ** 2
        + 0.5 * p.wheel_inertia * w**2
        + 0.5 * p.gear**2 * p.J_r_kgm2 * (w - w3) ** 2
        for w in (w1, w2)
    )
    # body (eq. 2.3 differentiated at psi = 0)
    xb = sd + l * np.cos(th3) * w3
    yb = l * np.sin(th3) * psid
    zb = l * np.sin(th3) * w3
    kb = 0.5 * p.m_b_kg * (xb**2 + yb**2 + zb**2) + 0.5 * p.J_A_kgm2 * w3**2 + 0.5 * p.J_B_kgm2 * psid**2
    return kw + kb


def mass_matrix_ref(th3, p):
    e = np.eye(3)
    M = np.empty((3, 3))
    for i in range(3):
        for j in range(3):
            if i == j:
                M[i, i] = 2 * kinetic_energy(th3, e[i], p)
            else:
                M[i, j] = (
                    kinetic_energy(th3, e[i] + e[j], p)
                    - kinetic_energy(th3, e[i], p)
                    - kinetic_energy(th3, e[j], p)
                )
    return M


def derivatives_ref(x, u, p):
    x = np.asarray(x, float)
    th3 = x[2]
    qd = x[3:6]
    cur = x[6:8]
    h = 1e-6
    M = mass_matrix_ref(th3, p)
    dM = (mass_matrix_ref(th3 + h, p) - mass_matrix_ref(th3 - h, p)) / (2 * h)
    V = (
        dM @ qd * qd[2]
        - np.array([0, 0, 0.5 * qd @ dM @ qd])
        + np.array([0, 0, p.m_b_kg * p.g_ms2 * p.l_m * np.sin(th3)])
    )
    km = p.k_M_NmA * p.gear
    tau_a = km * np.array([cur[0], cur[1], -cur[0] - cur[1]])
    fm, fw = p.f_m_Nms, p.f_w_Nms
    Ff = np.array([[fm + fw, 0, -fm], [0, fm + fw, -fm], [-fm, -fm, 2 * fm]])
    qdd = np.linalg.solve(M, tau_a - Ff @ qd - V)
    S = np.array([[1, 0, -1], [0, 1, -1]])
    idot = (np.asarray(u, float) - p.k_E_Vs * p.gear * S @ qd - p.R_ohm * cur) / p.L_H
    return np.concatenate([qd, qdd, idot])


def energy_ref(x, p):
    """Mechanical energy K + P (eq. 2.7) of state x."""
    return (
        kinetic_energy(x[2], x[3:6], p)
        + 2 * p.m_w_kg * p.g_ms2 * p.r_m
        + p.m_b_kg * p.g_ms2 * (p.r_m - p.l_m * np.cos(x[2]))
    )


def steady_state_ref(u, p):
    """Steady straight motion under equal voltages u: wheel rate (rad/s), current (A), theta3 (rad).

    From eqs. 2.8-2.11 with all accelerations and dtheta3 zero: k_M k I = (f_m + f_w) w (wheel),
    u = k_E k w + R I (electrics), m_b g l sin(theta3) = -2 k_M k I + 2 f_m w (body).
    """
    kmk, kek = p.k_M_NmA * p.gear, p.k_E_Vs * p.gear
    w = u / (kek + p.R_ohm * (p.f_m_Nms + p.f_w_Nms) / kmk)
    i = (p.f_m_Nms + p.f_w_Nms) * w / kmk
    th3 = np.arcsin((-2 * kmk * i + 2 * p.f_m_Nms * w) / (p.m_b_kg * p.g_ms2 * p.l_m))
    return w, i, th3
