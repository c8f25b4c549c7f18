"""Loop frequency response, gain and phase margins and the maximum sensitivity Ms (LTI plants).

The loop is broken at plant input 0: ``L(z) = sum_j G_j(z) P_j(z)`` with ``G_j = -du/dy_j`` the
controller's feedback transfer function from output ``j`` (from state ``j`` for state feedback) and
``P_j`` the discrete plant with its delay, evaluated at ``z = e^{j w h}`` on a log grid up to the
Nyquist frequency. ``Ms = max |1 / (1 + L)|``; the phase margin is ``180 deg + arg L`` at the gain
crossover(s) ``|L| = 1`` (the smallest), the gain margin ``-20 log10 |L|`` at the phase crossover(s)
``arg L = -180 deg (mod 360)`` (the smallest; ``inf`` if the phase never crosses). The grid has
:data:`N_FREQ` points from ``1e-4`` times the Nyquist frequency; crossings are interpolated linearly
in ``log w``. A closed loop that is unstable is not detected here (its simulation shows it).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

__all__ = ["frequency_grid", "loop_response", "margins", "N_FREQ"]

N_FREQ = 1500


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
