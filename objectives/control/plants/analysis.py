"""Loop frequency response, gain and phase margins and the maximum sensitivity Ms (LTI plants).

The loop is broken at plant input 0: ``L(z) = sum_j G_j(z) P_j(z)`` with ``G_j = -du/dy_j`` the
controller's feedback transfer function from output ``j`` (from state ``j`` for state feedback) and
``P_j`` the discrete plant with its delay, evaluated at ``z = e^{j w h}`` on a log grid up to the
Nyquist frequency. ``Ms = max |1 / (1 + L)|``; the phase margin is ``180 deg + arg L`` at the gain
crossover(s) ``|L| = 1`` (the smallest), the gain margin ``-20 log10 |L|`` at the phase crossover(s)
``arg L = -180 deg (mod 360)`` (the smallest; ``inf`` if the phase never crosses). The grid has
:data:`N_FREQ` points from ``1e-4`` times the Nyquist frequency; crossings are interpolated linearly
in ``log w``. Margins say nothing about an unstable closed loop: :func:`closed_loop_poles` gives the
eigenvalues of the linear closed loop (plant, delay line, controller states), which the objective
checks first.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from objectives.control.kinds import KIND_CASCADE, KIND_PID, KIND_SF

__all__ = ["frequency_grid", "loop_response", "margins", "N_FREQ"]

N_FREQ = 800


def frequency_grid(period_s: float, n: int = N_FREQ) -> np.ndarray:
    """Log-spaced frequencies (rad/s) from 1e-4 to 0.999 times the Nyquist frequency pi / h."""
    wn = math.pi / period_s
    return np.logspace(math.log10(1e-4 * wn), math.log10(0.999 * wn), n)


def plant_response(plant: Any, omega: np.ndarray, states: bool) -> np.ndarray:
    """The plant's frequency response (precomputed once per objective): outputs or states."""
    return plant.state_frequency_response(omega) if states else plant.frequency_response(omega)


def loop_response(ctrl: Any, cp: np.ndarray, plant: Any, omega: np.ndarray, pr: dict[str, np.ndarray]) -> np.ndarray:
    """``L(e^{j w h})`` (len(w),) complex; ``pr`` holds :func:`plant_response` of "outputs"/"states"."""
    z = np.exp(1j * omega * plant.period_s)
    g = ctrl.feedback(cp, plant, z)
    key = "states" if "states" in g else "outputs"
    return np.sum(g[key] * pr[key], axis=1)


def _crossings(x: np.ndarray, level: float) -> np.ndarray:
    """Fractional indices where ``x`` crosses ``level``."""
    d = x - level
    i = np.flatnonzero(np.sign(d[:-1]) * np.sign(d[1:]) < 0)
    exact = np.flatnonzero(d == 0)
    frac = i + d[i] / (d[i] - d[i + 1])
    return np.sort(np.r_[frac, exact.astype(float)])


def _at(v: np.ndarray, f: np.ndarray) -> np.ndarray:
    i = np.minimum(np.floor(f).astype(int), v.size - 2)
    w = f - i
    return v[i] * (1 - w) + v[i + 1] * w


def margins(L: np.ndarray, omega: np.ndarray) -> dict[str, float]:
    """``ms``, ``gm_db``, ``pm_deg`` and the crossover frequencies ``wc_rad_s``, ``w180_rad_s``."""
    if not np.all(np.isfinite(L)):
        return {"ms": math.inf, "gm_db": -math.inf, "pm_deg": -math.inf, "wc_rad_s": math.nan,
                "w180_rad_s": math.nan}
    ms = float(np.max(1.0 / np.abs(1.0 + L)))
    logw = np.log10(omega)
    mag_db = 20 * np.log10(np.maximum(np.abs(L), 1e-300))
    phase = np.degrees(np.unwrap(np.angle(L)))
    pm, wc = math.inf, math.nan
    for f in _crossings(mag_db, 0.0):
        p = 180.0 + _at(phase, np.array([f]))[0]
        p = (p + 180.0) % 360.0 - 180.0
        if p < pm:
            pm, wc = float(p), float(10 ** _at(logw, np.array([f]))[0])
    gm, w180 = math.inf, math.nan
    lo, hi = math.floor((phase.min() + 180) / 360), math.ceil((phase.max() + 180) / 360)
    for j in range(lo, hi + 1):
        for f in _crossings(phase, -180.0 + 360.0 * j):
            g = -float(_at(mag_db, np.array([f]))[0])
            if abs(g) < abs(gm) or (gm == math.inf):
                gm, w180 = g, float(10 ** _at(logw, np.array([f]))[0])
    return {"ms": ms, "gm_db": gm, "pm_deg": pm, "wc_rad_s": wc, "w180_rad_s": w180}


def _pid_block_ss(cp: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The linear PID block (no limits) as ``x' = A x + B (r, y)``, ``u = C x + D (r, y)``; state
    ``(I, D_prev, yc_prev)`` with ``yc = c r - y`` (kernels module docstring)."""
    k, b, c, ki, ad, bd = cp[:6]
    # without integral action I is never driven and stays 0: its mode is left out (placed at 0)
    a = np.array([[1.0 if ki != 0 else 0.0, 0.0, 0.0], [0.0, ad, -bd], [0.0, 0.0, 0.0]])
    bm = np.array([[ki, -ki], [bd * c, -bd], [c, -1.0]])
    cm = np.array([[1.0, ad, -bd]])
    dm = np.array([[k * b + bd * c, -k - bd]])
    return a, bm, cm, dm


def _controller_ss(ctrl_kind: int, cp: np.ndarray, plant: Any) -> tuple[np.ndarray, ...]:
    """The controller's feedback path (reference 0) as a state space from the measured vector to u."""
    m = plant.n_inputs
    if ctrl_kind == KIND_SF:
        n, mm = int(cp[0]), int(cp[1])
        k = cp[2:2 + mm * n].reshape(mm, n)
        return np.zeros((0, 0)), np.zeros((0, n)), np.zeros((m, 0)), -k
    p = plant.n_outputs
    if ctrl_kind == KIND_PID:
        a, b, c, d = _pid_block_ss(cp)
        bm = np.zeros((3, p))
        bm[:, plant.output] = b[:, 1]
        dm = np.zeros((m, p))
        dm[0, plant.output] = d[0, 1]
        cm = np.zeros((m, 3))
        cm[0] = c[0]
        return a, bm, cm, dm
    if ctrl_kind == KIND_CASCADE:
        ao, bo, co, do = _pid_block_ss(cp[:10])
        ai, bi, ci, di = _pid_block_ss(cp[10:])
        o, i = plant.output, plant.inner_output
        # r_i = co xo + do[:,1] y_o; inner inputs (r_i, y_i)
        a = np.zeros((6, 6))
        a[:3, :3] = ao
        a[3:, :3] = bi[:, :1] @ co
        a[3:, 3:] = ai
        bm = np.zeros((6, p))
        bm[:3, o] = bo[:, 1]
        bm[3:, o] += bi[:, 0] * do[0, 1]
        bm[3:, i] += bi[:, 1]
        cm = np.zeros((m, 6))
        cm[0, :3] = di[0, 0] * co[0]
        cm[0, 3:] = ci[0]
        dm = np.zeros((m, p))
        dm[0, o] = di[0, 0] * do[0, 1]
        dm[0, i] += di[0, 1]
        return a, bm, cm, dm
    return np.zeros((0, 0)), np.zeros((0, p)), np.zeros((m, 0)), np.zeros((m, p))


def closed_loop_poles(ctrl_kind: int, cp: np.ndarray, plant: Any) -> np.ndarray:
    """Eigenvalues of the linear closed loop (no limits, reference 0) of an LTI plant: plant states,
    the input-delay line, the delayed input of the feedthrough, and the controller's states."""
    n, m, d = plant.n_states, plant.n_inputs, plant.delay_n
    ns = n + d * m + m
    fa = np.zeros((ns, ns))
    ga = np.zeros((ns, m))
    fa[:n, :n] = plant.Ad
    if d == 0:
        ga[:n] = plant.Bd  # the applied input is u itself
        ga[n + d * m:] = np.eye(m)  # w' = u (the previous applied input, for the feedthrough)
    else:
        ga[n:n + m] = np.eye(m)  # line slot 1 <- u
        for j in range(1, d):
            fa[n + j * m:n + (j + 1) * m, n + (j - 1) * m:n + j * m] = np.eye(m)
        last = slice(n + (d - 1) * m, n + d * m)
        fa[:n, last] = plant.Bd
        fa[n + d * m:, last] = np.eye(m)
    if ctrl_kind == KIND_SF:
        h = np.zeros((n, ns))
        h[:, :n] = np.eye(n)
    else:
        h = np.zeros((plant.n_outputs, ns))
        h[:, :n] = plant.Cd
        h[:, n + d * m:] = plant.Dd
    ac, bc, cc, dc = _controller_ss(ctrl_kind, cp, plant)
    nc = ac.shape[0]
    a = np.zeros((ns + nc, ns + nc))
    a[:ns, :ns] = fa + ga @ dc @ h
    a[:ns, ns:] = ga @ cc
    a[ns:, :ns] = bc @ h
    a[ns:, ns:] = ac
    return np.linalg.eigvals(a)
