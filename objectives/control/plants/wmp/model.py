"""The wheeled mobile pendulum (WMP) of thesis section 2.1: 8-state nonlinear model and closed loop.

State ``x = (theta1, theta2, theta3, dtheta1, dtheta2, dtheta3, I1, I2)`` (rad, rad/s, A): wheel
angles (absolute, about the axle), inner-body (IB) angle (0 = centre of mass straight below the axle,
positive = centre of mass ahead of the axle), their rates, motor currents. Inputs: motor terminal
voltages ``u = (u1, u2)`` (V). Outputs (eq. 2.12) ``y = (nu, theta3, omega3, xi, I_A)``: linear speed
``nu = r (dtheta1 + dtheta2) / 2`` (m/s), theta3 (rad), omega3 = dtheta3 (rad/s), yaw rate
``xi = r (dtheta2 - dtheta1) / d`` (rad/s), average current ``I_A = (I1 + I2) / 2`` (A).

Equations implemented (thesis numbers):

- inertia matrix M(q) and vector V(q, qdot): appendix eq. (2), checked here against a Lagrange
  derivation from eqs. 2.1-2.7 (tests/reference/wmp_reference.py derives them numerically from the
  Lagrangian; the appendix's ``m13 = ... - k^2 Jr`` is read as ``- k^2 J_r``). The appendix's
  ``3/2 m_w r^2`` assumes the wheels are uniform discs, ``J_w = m_w r^2 / 2`` (J_w is absent from
  Table 2.1); ``J_w_kgm2`` overrides it;
- motor electrics eq. 2.8, torques eq. 2.9, viscous friction eq. 2.10 (f_m,1 = f_m,2 = f_m and
  f_w,1 = f_w,2 = f_w), state equation 2.12.

Integration. The electrical time constant L/R = 26 uH / 2.3 Ohm = 11.3 us is four orders of magnitude
below the mechanical ones (pendulum ~ 0.5 s, electrically damped wheel ~ 30 ms), so explicit RK4 on
the full 8-state system would need a step below ~30 us (RK4's stability limit is h |lambda| < 2.78).
We integrate instead with a singular-perturbation RK4 plus an exact current transient: within a
substep ``h`` (default Ts/10 = 1 ms) the current is split into its quasi-static value
``I_ss = (u - k_E k (dtheta_i - dtheta3)) / R`` (eq. 2.8 with L dI/dt = 0), evaluated at every RK4
stage from the stage velocities, plus the transient ``(I_n - I_ss,n) exp(-R t / L)``, the exact
solution of eq. 2.8 for frozen velocities, whose torque impulse is added in closed form (it matters
at every voltage step of the controller). The scheme is unconditionally stable for the electrical
part (it runs even with h = Ts, ~900 L/R), fourth order for the mechanics, and drops only the current
lag ``(L/R) dI_ss/dt``, a relative error ~ (L/R) / tau_mech ~ 5e-4 independent of h. It is checked
against scipy's Radau on the full eq. 2.12 (tests/control/test_wmp.py).

Caching: the plant kernels and the closed-loop driver :func:`_simulate` use numba's on-disk cache.
The driver calls kernels of other modules (``controllers/kernels.py`` and the fuzzy steps), whose edits
numba's own cache would not notice (a cached driver once ran stale controller code); rule 3 of
:mod:`objectives.jit` keys its entry on the whole package's sources, so it is compiled once per machine
instead of once per worker process (~2-3 s each). ``controller_step`` and the steps it calls are
compiled into the driver (rule 2).

Sensors (thesis Table 1.1, sampled at Ts = 0.01 s, section 2.2.3.1): see :class:`SensorParams`.
"""

from __future__ import annotations

import math
from dataclasses import replace
from typing import Any

import numpy as np
from numba import njit

from objectives.control.plants.wmp.controllers.kernels import controller_step
from objectives.control.plants.wmp.params import (
    _D,
    _FM,
    _FW,
    _G,
    _IND,
    _JA,
    _JB,
    _JR,
    _JW,
    _K,
    _KE,
    _KM,
    _L,
    _MB,
    _MW,
    _R,
    _RES,
    _UMAX,
    SensorParams,
    WMPParams,
)
from objectives.jit import CACHE

__all__ = [
    "WMPParams",
    "SensorParams",
    "STATUS_OK",
    "STATUS_FELL",
    "STATUS_DIVERGED",
    "STATUS_NAMES",
    "derivatives",
    "simulate_open_loop",
    "simulate_closed_loop",
    "mass_matrix",
]

STATUS_OK = 0
STATUS_FELL = 1
STATUS_DIVERGED = 2
STATUS_NAMES = {STATUS_OK: "ok", STATUS_FELL: "fell", STATUS_DIVERGED: "diverged"}


# --------------------------------------------------------------------------------------------------
# model kernels
# --------------------------------------------------------------------------------------------------
@njit
def _accelerations(th3, w1, w2, w3, i1, i2, c, acc):
    """Solve M(q) qdd = tau_a - tau_f - V(q, qdot) (eqs. 2.9-2.11, appendix eq. 2) into acc (3,).

    Uses the structure of M (m11 = m22, m13 = m23) to solve in sum/difference coordinates.
    """
    l, r, d, mb = c[_L], c[_R], c[_D], c[_MB]
    k2jr = c[_K] * c[_K] * c[_JR]
    sn = math.sin(th3)
    cs = math.cos(th3)
    rd2 = r * r / (d * d)
    cc = l * l * rd2 * mb  # l^2 r^2 m_b / d^2
    m11 = c[_MW] * r * r + c[_JW] + 0.25 * mb * r * r + k2jr + cc * sn * sn + c[_JB] * rd2
    m12 = 0.25 * mb * r * r - cc * sn * sn - c[_JB] * rd2
    m13 = 0.5 * mb * l * r * cs - k2jr
    m33 = mb * l * l + c[_JA] + 2.0 * k2jr
    # V (appendix)
    wd = w1 - w2
    v1 = 2.0 * cc * sn * cs * w3 * wd - 0.5 * mb * l * r * sn * w3 * w3
    v2 = -2.0 * cc * sn * cs * w3 * wd - 0.5 * mb * l * r * sn * w3 * w3
    v3 = -cc * sn * cs * wd * wd + mb * c[_G] * l * sn
    # torques (2.9) and friction (2.10)
    km = c[_KM] * c[_K]
    fm, fw = c[_FM], c[_FW]
    f1 = km * i1 - ((fm + fw) * w1 - fm * w3) - v1
    f2 = km * i2 - ((fm + fw) * w2 - fm * w3) - v2
    f3 = -km * (i1 + i2) - (-fm * w1 - fm * w2 + 2.0 * fm * w3) - v3
    a = m11 + m12
    det = a * m33 - 2.0 * m13 * m13
    sig = ((f1 + f2) * m33 - 2.0 * m13 * f3) / det
    acc[2] = (a * f3 - m13 * (f1 + f2)) / det
    dlt = (f1 - f2) / (m11 - m12)
    acc[0] = 0.5 * (sig + dlt)
    acc[1] = 0.5 * (sig - dlt)


@njit(cache=True)
def _derivatives(x, u, c, out):
    """Full state equation 2.12: out (8,) = h(x, u) (rad/s, rad/s^2, A/s)."""
    acc = np.empty(3)
    _accelerations(x[2], x[3], x[4], x[5], x[6], x[7], c, acc)
    out[0] = x[3]
    out[1] = x[4]
    out[2] = x[5]
    out[3] = acc[0]
    out[4] = acc[1]
    out[5] = acc[2]
    ke = c[_KE] * c[_K]
    out[6] = (u[0] - ke * (x[3] - x[5]) - c[_RES] * x[6]) / c[_IND]
    out[7] = (u[1] - ke * (x[4] - x[5]) - c[_RES] * x[7]) / c[_IND]


@njit
def _stage(x, kq, kw, a, u0, u1, dI1, dI2, decay, c, outq, outw, acc):
    """One RK4 stage at x + a*(kq, kw); currents = quasi-static + ``decay`` times the transient."""
    th3 = x[2] + a * kq[2]
    w1 = x[3] + a * kw[0]
    w2 = x[4] + a * kw[1]
    w3 = x[5] + a * kw[2]
    ke = c[_KE] * c[_K]
    i1 = (u0 - ke * (w1 - w3)) / c[_RES] + dI1 * decay
    i2 = (u1 - ke * (w2 - w3)) / c[_RES] + dI2 * decay
    _accelerations(th3, w1, w2, w3, i1, i2, c, acc)
    outq[0] = w1
    outq[1] = w2
    outq[2] = w3
    outw[0] = acc[0]
    outw[1] = acc[1]
    outw[2] = acc[2]


@njit
def _step(x, u0, u1, h, c, s):
    """Advance x (8,) in place by h with constant voltages (exponential/singular-perturbation RK4).

    s is a (27,) scratch array (no allocation per step).
    """
    ke = c[_KE] * c[_K]
    res = c[_RES]
    tau = c[_IND] / res
    dI1 = x[6] - (u0 - ke * (x[3] - x[5])) / res
    dI2 = x[7] - (u1 - ke * (x[4] - x[5])) / res
    e_full = math.exp(-h / tau)
    k1q, k1w = s[0:3], s[3:6]
    for j in range(6):  # stage 1 reads x + 0 * k1: k1 must hold finite numbers
        s[j] = 0.0
    k2q, k2w = s[6:9], s[9:12]
    k3q, k3w = s[12:15], s[15:18]
    k4q, k4w = s[18:21], s[21:24]
    acc = s[24:27]
    # mechanics with the quasi-static current (RK4)
    _stage(x, k1q, k1w, 0.0, u0, u1, dI1, dI2, 0.0, c, k1q, k1w, acc)
    _stage(x, k1q, k1w, 0.5 * h, u0, u1, dI1, dI2, 0.0, c, k2q, k2w, acc)
    _stage(x, k2q, k2w, 0.5 * h, u0, u1, dI1, dI2, 0.0, c, k3q, k3w, acc)
    _stage(x, k3q, k3w, h, u0, u1, dI1, dI2, 0.0, c, k4q, k4w, acc)
    # the transient current (I_n - I_ss) exp(-t R / L) adds a torque impulse integrated exactly
    # (M and the other forces frozen over the ~10 us it lasts): acc difference times its integrals
    i1 = (u0 - ke * (x[3] - x[5])) / res
    i2 = (u1 - ke * (x[4] - x[5])) / res
    _accelerations(x[2], x[3], x[4], x[5], i1 + dI1, i2 + dI2, c, acc)
    a0, a1, a2 = acc[0], acc[1], acc[2]
    _accelerations(x[2], x[3], x[4], x[5], i1, i2, c, acc)
    phi1 = tau * (1.0 - e_full)  # int_0^h exp(-t/tau) dt
    phi2 = tau * h - tau * phi1  # int_0^h int_0^t exp(-s/tau) ds dt
    da0, da1, da2 = a0 - acc[0], a1 - acc[1], a2 - acc[2]
    for j in range(3):
        x[j] += h / 6.0 * (k1q[j] + 2.0 * k2q[j] + 2.0 * k3q[j] + k4q[j])
        x[3 + j] += h / 6.0 * (k1w[j] + 2.0 * k2w[j] + 2.0 * k3w[j] + k4w[j])
    x[0] += phi2 * da0
    x[1] += phi2 * da1
    x[2] += phi2 * da2
    x[3] += phi1 * da0
    x[4] += phi1 * da1
    x[5] += phi1 * da2
    x[6] = (u0 - ke * (x[3] - x[5])) / res + dI1 * e_full
    x[7] = (u1 - ke * (x[4] - x[5])) / res + dI2 * e_full


@njit
def _quant(v, lsb):
    if lsb > 0.0:
        return lsb * math.floor(v / lsb + 0.5)
    return v


@njit(cache=CACHE)  # calls kernels of other modules: cached under rule 3 of objectives.jit
def _simulate(x0, c, sc, ref, noise, kind, cp, cs, n_sub, fall_limit, x_out, y_out, m_out, u_out):
    """Closed loop over the whole profile in one call.

    Parameters
    ----------
    x0 : (8,) initial state.  c : (18,) plant coefficients.  sc : (13,) sensor coefficients.
    ref : (N, 2) nu_d (m/s), xi_d (rad/s) per controller period.
    noise : (N, 4) standard normal draws (gyro, acc forward, acc up, current).
    kind, cp, cs : controller kind, parameter array, state array (modified).
    n_sub : integration substeps per Ts.  fall_limit : |theta3| limit (rad).
    x_out (N, 8), y_out (N, 5), m_out (N, 5), u_out (N, 2) : per-sample state, true outputs,
        measurements and applied (saturated, quantised) voltages; rows after a failure stay NaN.

    Returns
    -------
    (status, n_done) : STATUS_* code and the number of completed samples.
    """
    n = ref.shape[0]
    ts = sc[11]
    h = ts / n_sub
    r, d, g = c[_R], c[_D], c[_G]
    umax = c[_UMAX]
    x = x0.copy()
    scratch = np.zeros(27)
    acc = np.empty(3)
    meas = np.empty(5)
    u = np.zeros(2)
    rk = np.empty(2)
    # Kalman filter (eq. 2.20) state and covariance
    th_hat = x[2]
    b_hat = 0.0
    p00 = sc[10]
    p01 = 0.0
    p11 = 1e-6
    enc1_prev = _quant(x[0] - x[2], sc[5])
    enc2_prev = _quant(x[1] - x[2], sc[5])
    for k in range(n):
        # --- true outputs and sensors at t = k Ts
        _accelerations(x[2], x[3], x[4], x[5], x[6], x[7], c, acc)
        y_out[k, 0] = 0.5 * r * (x[3] + x[4])
        y_out[k, 1] = x[2]
        y_out[k, 2] = x[5]
        y_out[k, 3] = r * (x[4] - x[3]) / d
        y_out[k, 4] = 0.5 * (x[6] + x[7])
        for j in range(8):
            x_out[k, j] = x[j]
        gyro = _quant(x[5] + sc[2] + sc[0] * noise[k, 0], sc[1])
        sdd = 0.5 * r * (acc[0] + acc[1])
        sn = math.sin(x[2])
        cn = math.cos(x[2])
        a_f = _quant(sdd * cn + g * sn + sc[3] * noise[k, 1], sc[4])
        a_u = _quant(g * cn - sdd * sn + sc[3] * noise[k, 2], sc[4])
        th_acc = math.atan2(a_f, a_u)
        enc1 = _quant(x[0] - x[2], sc[5])
        enc2 = _quant(x[1] - x[2], sc[5])
        if k > 0:
            # KF predict with the gyro as input, then update with the accelerometer angle
            th_hat += ts * (gyro - b_hat)
            q00 = p00 - ts * (p01 + p01) + ts * ts * p11 + sc[8]
            q01 = p01 - ts * p11
            q11 = p11 + sc[9]
            p00, p01, p11 = q00, q01, q11
        sk = p00 + sc[10]
        g0 = p00 / sk
        g1 = p01 / sk
        innov = th_acc - th_hat
        th_hat += g0 * innov
        b_hat += g1 * innov
        p11 = p11 - g1 * p01
        p01 = p01 - g0 * p01
        p00 = p00 - g0 * p00
        meas[0] = 0.5 * r * ((enc1 - enc1_prev) + (enc2 - enc2_prev)) / ts + r * gyro
        meas[1] = th_hat
        meas[2] = gyro
        meas[3] = r * ((enc2 - enc2_prev) - (enc1 - enc1_prev)) / (d * ts)
        meas[4] = _quant(0.5 * (x[6] + x[7]) + sc[6] * noise[k, 3], sc[7])
        enc1_prev = enc1
        enc2_prev = enc2
        for j in range(5):
            m_out[k, j] = meas[j]
        # --- controller
        rk[0] = ref[k, 0]
        rk[1] = ref[k, 1]
        controller_step(kind, cp, cs, rk, meas, x, r, d, u)
        for j in range(2):
            if not math.isfinite(u[j]):
                return 2, k
            if u[j] > umax:
                u[j] = umax
            elif u[j] < -umax:
                u[j] = -umax
            u[j] = _quant(u[j], sc[12])
            u_out[k, j] = u[j]
        # --- plant over one period
        for _ in range(n_sub):
            _step(x, u[0], u[1], h, c, scratch)
        bad = False
        for j in range(8):
            if not math.isfinite(x[j]):
                bad = True
        if bad or abs(x[3]) > 1e4 or abs(x[4]) > 1e4 or abs(x[5]) > 1e4:
            return 2, k + 1
        if abs(x[2]) > fall_limit:
            return 1, k + 1
    return 0, n


# --------------------------------------------------------------------------------------------------
# public wrappers
# --------------------------------------------------------------------------------------------------
def derivatives(x: np.ndarray, u: np.ndarray, params: WMPParams | None = None) -> np.ndarray:
    """State derivative of eq. 2.12, shape (8,), for state x (8,) and voltages u (2,)."""
    x = np.ascontiguousarray(x, dtype=float)
    u = np.ascontiguousarray(u, dtype=float)
    if x.shape != (8,) or u.shape != (2,):
        raise ValueError(f"expected x of shape (8,) and u of shape (2,), got {x.shape} and {u.shape}")
    out = np.empty(8)
    _derivatives(x, u, (params or WMPParams()).coeffs(), out)
    return out


def mass_matrix(theta3: float, params: WMPParams | None = None) -> np.ndarray:
    """M(q) of appendix eq. (2), shape (3, 3) (kg m^2)."""
    p = params or WMPParams()
    sn, cs = math.sin(theta3), math.cos(theta3)
    k2jr = p.gear**2 * p.J_r_kgm2
    rd2 = p.r_m**2 / p.d_m**2
    cc = p.l_m**2 * rd2 * p.m_b_kg
    m11 = (
        p.m_w_kg * p.r_m**2
        + p.wheel_inertia
        + 0.25 * p.m_b_kg * p.r_m**2
        + k2jr
        + cc * sn**2
        + p.J_B_kgm2 * rd2
    )
    m12 = 0.25 * p.m_b_kg * p.r_m**2 - cc * sn**2 - p.J_B_kgm2 * rd2
    m13 = 0.5 * p.m_b_kg * p.l_m * p.r_m * cs - k2jr
    m33 = p.m_b_kg * p.l_m**2 + p.J_A_kgm2 + 2 * k2jr
    return np.array([[m11, m12, m13], [m12, m11, m13], [m13, m13, m33]])


def _check_common(n_sub: int, x0: np.ndarray | None) -> np.ndarray:
    if not isinstance(n_sub, (int, np.integer)) or n_sub < 1:
        raise ValueError(f"n_sub must be a positive integer, got {n_sub!r}")
    x0 = np.zeros(8) if x0 is None else np.ascontiguousarray(x0, dtype=float).copy()
    if x0.shape != (8,) or not np.all(np.isfinite(x0)):
        raise ValueError(f"x0 must be a finite array of shape (8,), got {x0!r}")
    return x0


def simulate_closed_loop(
    kind: int,
    cparams: np.ndarray,
    state_size: int,
    ref: np.ndarray,
    noise: np.ndarray | None = None,
    params: WMPParams | None = None,
    sensors: SensorParams | None = None,
    x0: np.ndarray | None = None,
    n_sub: int = 10,
    fall_limit_deg: float = 90.0,
) -> dict[str, Any]:
    """Run the closed loop over a reference profile (one kernel call).

    Parameters
    ----------
    kind : controller kind (:mod:`objectives.control.kinds`, ``KIND_WMP_*``).
    cparams : (p,) controller parameter array; state_size : length of its zeroed state array.
    ref : (N, 2) desired speed (m/s) and yaw rate (rad/s), one row per controller period.
    noise : (N, 4) standard normal draws; ``None`` means noise-free (zeros).
    params, sensors : plant and sensor parameters (Table 2.1, Table 1.1 defaults).
    x0 : (8,) initial state (rest by default). n_sub : substeps per Ts. fall_limit_deg : |theta3|
        beyond which the robot counts as fallen (deg).

    Returns
    -------
    dict with ``t`` (N,) s, ``x`` (N, 8), ``y`` (N, 5) true outputs, ``meas`` (N, 5) sensed signals,
    ``u`` (N, 2) applied voltages, ``status`` (int), ``status_name``, ``n_done`` (int). Rows from
    ``n_done`` on are NaN when the run stopped early.
    """
    params = params or WMPParams()
    sensors = sensors or SensorParams()
    x0 = _check_common(n_sub, x0)
    ref = np.ascontiguousarray(ref, dtype=float)
    if ref.ndim != 2 or ref.shape[1] != 2 or ref.shape[0] < 1 or not np.all(np.isfinite(ref)):
        raise ValueError(f"ref must be a finite (N, 2) array, got shape {ref.shape}")
    n = ref.shape[0]
    if noise is None:
        noise = np.zeros((n, 4))
    noise = np.ascontiguousarray(noise, dtype=float)
    if noise.shape != (n, 4):
        raise ValueError(f"noise must have shape ({n}, 4), got {noise.shape}")
    if not 0 < fall_limit_deg <= 180:
        raise ValueError(f"fall_limit_deg must be in (0, 180], got {fall_limit_deg}")
    cp = np.ascontiguousarray(cparams, dtype=float)
    cs = np.zeros(int(state_size))
    x_out = np.full((n, 8), np.nan)
    y_out = np.full((n, 5), np.nan)
    m_out = np.full((n, 5), np.nan)
    u_out = np.full((n, 2), np.nan)
    status, n_done = _simulate(
        x0,
        params.coeffs(),
        sensors.coeffs(params.u_max_V),
        ref,
        noise,
        int(kind),
        cp,
        cs,
        int(n_sub),
        math.radians(fall_limit_deg),
        x_out,
        y_out,
        m_out,
        u_out,
    )
    return {
        "t": np.arange(n) * sensors.Ts_s,
        "x": x_out,
        "y": y_out,
        "meas": m_out,
        "u": u_out,
        "status": int(status),
        "status_name": STATUS_NAMES[int(status)],
        "n_done": int(n_done),
    }


def simulate_open_loop(
    u: tuple[float, float],
    duration_s: float,
    params: WMPParams | None = None,
    x0: np.ndarray | None = None,
    Ts_s: float = 0.01,
    n_sub: int = 10,
    fall_limit_deg: float = 180.0,
) -> dict[str, Any]:
    """Constant voltages ``u`` (V) for ``duration_s`` with ideal sensors; same output as closed loop."""
    from objectives.control.kinds import KIND_WMP_OPEN

    n = int(round(duration_s / Ts_s))
    if n < 1:
        raise ValueError(f"duration_s={duration_s} is shorter than one period Ts={Ts_s}")
    return simulate_closed_loop(
        KIND_WMP_OPEN,
        np.asarray(u, float),
        0,
        np.zeros((n, 2)),
        None,
        params,
        replace(SensorParams.ideal(Ts_s), pwm_bits=0),
        x0,
        n_sub,
        fall_limit_deg,
    )
