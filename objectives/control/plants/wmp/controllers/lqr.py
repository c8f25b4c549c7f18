"""LQR and LQG of thesis section 2.2.1 for the wheeled mobile pendulum.

Design steps (section 2.2.1.2):

1. linearise eq. 2.12 about (x_e, u_e) = (0, 0) (eq. 2.17) by central differences of the kernel's
   state derivative (:func:`linearize`; checked against the analytic form in the tests);
2. remove the motor electrics by singular perturbation (L -> 0: the 26 uH inductance gives an
   11 us pole, far beyond the 100 Hz controller); the thesis's design state has no currents either;
3. change coordinates to x~ = (s, theta3, ds, dtheta3, psi, dpsi) (eq. 2.18) and keep the
   controllable subsystem z_C = (theta3, nu, omega3, xi) (eq. 2.19; s and psi are pure integrators of
   nu and xi that nothing feeds back, which is why the thesis drops them);
4. discretise (A_C, B_C) at Ts with a zero-order hold and solve the discrete Riccati equation
   with Q = diag(q_theta3, q_nu, q_omega3, q_xi), R = diag(r_u1, r_u2). MATLAB's ``lqrd`` used in
   the thesis weights the continuous cost; with diagonal weights this differs from the discrete
   weights used here by O(Ts) terms (scaling both Q and R by Ts leaves K unchanged);
5. reference tracking matrices N_x, N_u of eq. 2.15 for the outputs (nu, xi):
   u = -K z + (N_u + K N_x) r.

``LQR`` feeds back the true state (perfect measurement, the design assumption); ``LQG`` feeds back
the measured speed, gyro rate and yaw rate and the Kalman estimate of theta3 (eq. 2.20), which the
closed-loop kernel computes from the simulated accelerometer and gyroscope.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import scipy.linalg

from objectives.control.kinds import KIND_WMP_LQG, KIND_WMP_LQR
from objectives.control.plants.wmp.controllers.base import Controller
from objectives.control.plants.wmp.model import WMPParams, derivatives
from objectives.params import NONNEG, POSITIVE, Param, ParamSet

__all__ = ["LQR", "LQG", "LQDesign", "linearize", "reduced_model", "lq_design"]


def linearize(params: WMPParams | None = None, eps: float = 1e-6) -> tuple[np.ndarray, np.ndarray]:
    """Jacobians A (8, 8) and B (8, 2) of eq. 2.12 at x = 0, u = 0 (eq. 2.17), central differences."""
    params = params or WMPParams()
    x0, u0 = np.zeros(8), np.zeros(2)
    A = np.empty((8, 8))
    B = np.empty((8, 2))
    for j in range(8):
        dx = np.zeros(8)
        dx[j] = eps
        A[:, j] = (derivatives(x0 + dx, u0, params) - derivatives(x0 - dx, u0, params)) / (2 * eps)
    for j in range(2):
        du = np.zeros(2)
        du[j] = eps
        B[:, j] = (derivatives(x0, u0 + du, params) - derivatives(x0, u0 - du, params)) / (2 * eps)
    return A, B


def reduced_model(params: WMPParams | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Controllable subsystem (A_C (4, 4), B_C (4, 2), C_C (2, 4)) in z_C = (theta3, nu, omega3, xi).

    Also returns, via the steps in the module docstring, a model in SI units: rad, m/s, rad/s, rad/s.
    """
    params = params or WMPParams()
    A, B = linearize(params)
    # singular perturbation of the currents: I = -A22^-1 (A21 x_m + B2 u)
    A11, A12, A21, A22 = A[:6, :6], A[:6, 6:], A[6:, :6], A[6:, 6:]
    B2 = B[6:, :]
    A22i = np.linalg.inv(A22)
    Am = A11 - A12 @ A22i @ A21
    Bm = -A12 @ A22i @ B2
    r, d = params.r_m, params.d_m
    # x~ = T x_m, x_m = (th1, th2, th3, w1, w2, w3)
    T = np.zeros((6, 6))
    T[0, 0] = T[0, 1] = r / 2  # s
    T[1, 2] = 1.0  # theta3
    T[2, 3] = T[2, 4] = r / 2  # ds
    T[3, 5] = 1.0  # dtheta3
    T[4, 0], T[4, 1] = -r / d, r / d  # psi
    T[5, 3], T[5, 4] = -r / d, r / d  # dpsi
    Ti = np.linalg.inv(T)
    At = T @ Am @ Ti
    Bt = T @ Bm
    idx = [1, 2, 3, 5]
    Ac = At[np.ix_(idx, idx)]
    Bc = Bt[idx, :]
    Cc = np.zeros((2, 4))
    Cc[0, 1] = 1.0
    Cc[1, 3] = 1.0
    return Ac, Bc, Cc


@dataclass(frozen=True)
class LQDesign:
    """Result of :func:`lq_design`: the discrete LQR of eq. 2.13 with the tracking matrices of eq. 2.15.

    The control law is ``u = -K z + Fr r`` on the design state ``z = (theta3, nu, omega3, xi)``
    (rad, m/s, rad/s, rad/s) and the reference ``r = (nu, xi)`` (m/s, rad/s); ``u`` in V.

    Attributes
    ----------
    K : ndarray (2, 4)
        Feedback gain, ``K = (R + Bd' P Bd)^-1 Bd' P Ad``.
    Nx : ndarray (4, 2)
        Steady state per unit reference (eq. 2.15): ``z_ss = Nx r``.
    Nu : ndarray (2, 2)
        Steady input per unit reference (eq. 2.15): ``u_ss = Nu r``.
    Fr : ndarray (2, 2)
        Reference feed-forward ``Nu + K Nx``.
    P : ndarray (4, 4)
        Solution of the discrete algebraic Riccati equation (cost-to-go ``z' P z``).
    Ad, Bd : ndarray (4, 4), (4, 2)
        Zero-order-hold discretisation of the controllable subsystem at ``Ts``.
    Cc : ndarray (2, 4)
        Output matrix of ``(nu, xi)``.
    poles : ndarray (4,) complex
        Closed-loop eigenvalues of ``Ad - Bd K`` (inside the unit circle for a stabilising design).
    """

    K: np.ndarray
    Nx: np.ndarray
    Nu: np.ndarray
    Fr: np.ndarray
    P: np.ndarray
    Ad: np.ndarray
    Bd: np.ndarray
    Cc: np.ndarray
    poles: np.ndarray


def lq_design(
    q: np.ndarray, rw: np.ndarray, Ts: float, params: WMPParams | None = None, model: tuple | None = None
) -> LQDesign:
    """Discrete LQR gain K (2, 4) and tracking matrices of eq. 2.15 for diagonal weights q (4,), rw (2,).

    ``model`` is a precomputed :func:`reduced_model` of ``params`` (it does not depend on the weights).
    Returns an :class:`LQDesign` (K, Nx, Nu, Fr = Nu + K Nx, P, Ad, Bd, Cc, closed-loop poles).
    """
    q = np.asarray(q, float)
    rw = np.asarray(rw, float)
    if q.shape != (4,) or rw.shape != (2,) or np.any(q < 0) or np.any(rw <= 0):
        raise ValueError(f"need q (4,) >= 0 and r (2,) > 0, got q={q}, r={rw}")
    Ac, Bc, Cc = reduced_model(params) if model is None else model
    # ZOH discretisation via the augmented matrix exponential
    M = np.zeros((6, 6))
    M[:4, :4] = Ac * Ts
    M[:4, 4:] = Bc * Ts
    E = scipy.linalg.expm(M)
    Ad, Bd = E[:4, :4], E[:4, 4:]
    Q, R = np.diag(q), np.diag(rw)
    P = scipy.linalg.solve_discrete_are(Ad, Bd, Q, R)
    K = np.linalg.solve(R + Bd.T @ P @ Bd, Bd.T @ P @ Ad)
    big = np.block([[Ad - np.eye(4), Bd], [Cc, np.zeros((2, 2))]])
    rhs = np.vstack([np.zeros((4, 2)), np.eye(2)])
    N = np.linalg.solve(big, rhs)
    Nx, Nu = N[:4], N[4:]
    return LQDesign(K=K, Nx=Nx, Nu=Nu, Fr=Nu + K @ Nx, P=P, Ad=Ad, Bd=Bd, Cc=Cc, poles=np.linalg.eigvals(Ad - Bd @ K))


_Q = dict(scale="log", eq="eq. 2.13 Q (Q >= 0), section 2.2.1.2", allowed=NONNEG)
_R = dict(scale="log", eq="eq. 2.13 R (R > 0), section 2.2.1.2", allowed=POSITIVE)
#: LQR/LQG weights: the thesis's heuristic Q, R (section 2.2.1.2), bounds two decades either side
_LQ_WEIGHTS = (
    Param("q_theta3", 14.5, (0.1, 1.0e4), unit="1/rad^2", doc="Q11, IB angle weight", **_Q),
    Param("q_nu", 156.2, (1.0, 1.0e5), unit="s^2/m^2", doc="Q22, linear speed weight", **_Q),
    Param("q_omega3", 1.3, (1.0e-2, 1.0e3), unit="s^2/rad^2", doc="Q33, IB rate weight", **_Q),
    Param("q_xi", 1.3, (1.0e-2, 1.0e3), unit="s^2/rad^2", doc="Q44, yaw rate weight", **_Q),
    Param("r_u1", 0.1, (1.0e-3, 10.0), unit="1/V^2", doc="R11, left motor voltage weight", **_R),
    Param("r_u2", 0.1, (1.0e-3, 10.0), unit="1/V^2", doc="R22, right motor voltage weight", **_R),
)


class LQR(Controller):
    """Discrete LQR with reference tracking (eqs. 2.13-2.15, 2.19) on the true state.

    Defaults are the thesis's heuristic weights Q = diag(14.5, 156.2, 1.3, 1.3), R = diag(0.1, 0.1)
    (section 2.2.1.2); bounds span two decades either side on a log scale.
    """

    name = "lqr"
    kind = KIND_WMP_LQR
    state_size = 0
    decl = ParamSet("controller 'lqr'", _LQ_WEIGHTS)

    def design(self, values=None) -> LQDesign:
        v = self.resolve(values)
        q = [v["q_theta3"], v["q_nu"], v["q_omega3"], v["q_xi"]]
        if getattr(self, "_model", None) is None:
            self._model = reduced_model(self.plant)  # the linearisation does not depend on Q, R
        return lq_design(q, [v["r_u1"], v["r_u2"]], self.sensors.Ts_s, self.plant, self._model)

    def _build(self, values):
        des = self.design(values)
        return np.concatenate([des.K.ravel(), des.Fr.ravel()])

    def export_tables(self, values: dict[str, Any] | None = None) -> dict[str, dict[str, Any]]:
        """What the firmware runs, for ``tuner export``: ``u = -K z + Fr r`` (eqs. 2.13-2.15, 2.19).

        Matrices of :meth:`design` for ``values`` (no input ranges: :func:`tuner.export_formats.to_c`
        writes them as ``double[rows][cols]``) with the design state ``z = (theta3, nu, omega3, xi)``
        (rad, m/s, rad/s, rad/s), reference ``r = (nu, xi)`` (m/s, rad/s) and ``u`` in V.
        """
        des = self.design(values)
        z, r = "z = (theta3 rad, nu m/s, omega3 rad/s, xi rad/s)", "r = (nu m/s, xi rad/s)"
        return {
            "K": {"table": des.K, "doc": f"feedback gain of u = -K z + Fr r, eq. 2.13; {z}", "unit": "V per unit of z"},
            "Nx": {"table": des.Nx, "doc": f"steady state per unit reference, z_ss = Nx r, eq. 2.15; {r}",
                   "unit": "unit of z per unit of r"},
            "Nu": {"table": des.Nu, "doc": "steady input per unit reference, u_ss = Nu r, eq. 2.15",
                   "unit": "V per unit of r"},
            "Fr": {"table": des.Fr, "doc": "reference feed-forward Fr = Nu + K Nx", "unit": "V per unit of r"},
        }


class LQG(LQR):
    """LQR gains on measured signals with the KF estimate of theta3 (eq. 2.20, separation principle)."""

    name = "lqg"
    kind = KIND_WMP_LQG
    decl = LQR.decl.with_owner("controller 'lqg'")
