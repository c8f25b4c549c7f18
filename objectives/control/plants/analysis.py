"""Loop frequency response, gain and phase margins and the maximum sensitivity Ms (LTI plants).

The loop is broken at plant input 0: ``L(z) = sum_j G_j(z) P_j(z)`` with ``G_j = -du/dy_j`` the
controller's feedback transfer function from output ``j`` (from state ``j`` for state feedback) and
``P_j`` the discrete plant with its delay, evaluated at ``z = e^{j w h}``. ``Ms = max |1 / (1 + L)|``
over ``0 < w <= pi / h``; the phase margin is ``180 deg + arg L`` at the gain crossover(s) ``|L| = 1``
(the smallest), the gain margin ``-20 log10 |L|`` at the phase crossover(s) ``arg L = -180 deg (mod 360)``
(the smallest in magnitude; ``inf`` if the phase never crosses).

Two steps (:func:`margins`): a log grid of :data:`N_FREQ` points from ``1e-4`` to ``0.999`` times the
Nyquist frequency ``pi / h`` finds the extrema and crossings; then, given the exact loop response at any
frequency (``exact``, the rational ``L(e^{j w h})`` of the discrete plant and controller), each of the
:data:`N_PEAKS` highest local maxima of ``|S|`` and every crossing is refined by :data:`ZOOM_ROUNDS`
rounds of a :data:`ZOOM_POINTS`-point grid on the bracket of the round before (the bracket of a grid
point is its two neighbours, up to ``pi / h`` for the last one). A bracket of one grid step shrinks by
``(ZOOM_POINTS - 1) / 2`` per round, to about ``6e-6`` of the frequency, so the refined Ms is the peak's
to far below ``1e-6`` (it is never below the grid's maximum: the refinement only adds frequencies); a
crossing is then interpolated linearly in that bracket, exact to about ``1e-10`` relative. The
:data:`N_CROSSINGS` crossings of each kind whose grid margin is the smallest are refined (a delay makes
the phase cross -180 deg many times). Without ``exact`` the grid's values are returned
(crossings interpolated linearly in ``log w``): up to ``2e-3`` low in Ms on sharp peaks.

Margins say nothing about an unstable closed loop: :func:`closed_loop_poles` gives the eigenvalues of the
linear closed loop (plant, delay line, controller states), which the objective checks first.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np

from objectives.control.kinds import KIND_CASCADE, KIND_PID, KIND_SF

__all__ = ["frequency_grid", "loop_response", "exact_loop", "margins", "closed_loop_poles", "N_FREQ", "N_PEAKS",
           "N_CROSSINGS", "ZOOM_ROUNDS", "ZOOM_POINTS"]

N_FREQ = 800
#: the local maxima of |S| on the grid that are refined (the highest ones)
N_PEAKS = 3
#: refinement: rounds, and points per round on the bracket
ZOOM_ROUNDS = 3
ZOOM_POINTS = 33
#: the crossings refined for each margin: those whose grid value is among the smallest
N_CROSSINGS = 2


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


def exact_loop(ctrl: Any, cp: np.ndarray, plant: Any, states: bool) -> Callable[[np.ndarray], np.ndarray]:
    """``L`` at any frequencies (rad/s): the plant's response computed there (no grid)."""

    def loop(omega: np.ndarray) -> np.ndarray:
        pr = {"outputs": plant.frequency_response(omega)}
        if states:
            pr["states"] = plant.state_frequency_response(omega)
        return loop_response(ctrl, cp, plant, omega, pr)

    return loop


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


def _zoom_grid(lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """(len(lo), ZOOM_POINTS) log-spaced frequencies from ``lo`` to ``hi`` (rows: brackets)."""
    s = np.linspace(0.0, 1.0, ZOOM_POINTS)
    return np.exp(np.log(lo)[:, None] + (np.log(hi) - np.log(lo))[:, None] * s[None, :])


#: what a bracket refines: the peak of |S|, a root of log|L| (gain crossover), a root of arg(-L) (phase crossover)
_PEAK, _GAIN, _PHASE = 0, 1, 2


def _values(kind: np.ndarray, L: np.ndarray) -> np.ndarray:
    """Per row of ``L`` the function its bracket's ``kind`` refines (|S| is maximised, the others are zero)."""
    v = np.empty(L.shape)
    with np.errstate(divide="ignore", invalid="ignore"):
        for k, fn in ((_PEAK, lambda x: 1.0 / np.abs(1.0 + x)), (_GAIN, lambda x: np.log(np.abs(x))),
                      (_PHASE, lambda x: np.angle(-x))):
            sel = kind == k
            if np.any(sel):
                v[sel] = fn(L[sel])
    return v


def _zoom(exact: Callable[[np.ndarray], np.ndarray], kind: np.ndarray, lo: np.ndarray,
          hi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Refine every bracket ``[lo_i, hi_i]`` at once (one call of ``exact`` per round, module docstring).

    Returns ``(w, L)``: per bracket the frequency found (the highest ``|S|`` seen for a peak, the root
    interpolated in the last bracket for a crossing, whose ends must differ in sign) and ``L`` there."""
    rows = np.arange(kind.size)
    best_w, best_s = np.full(kind.size, np.nan), np.full(kind.size, -np.inf)
    v_lo, v_hi = np.zeros(kind.size), np.zeros(kind.size)
    for _ in range(ZOOM_ROUNDS):
        w = _zoom_grid(lo, hi)
        v = _values(kind, exact(w.ravel()).reshape(w.shape))
        jp = np.argmax(np.where(np.isnan(v), np.inf, v), axis=1)
        better = v[rows, jp] > best_s
        best_s = np.where(better, v[rows, jp], best_s)
        best_w = np.where(better, w[rows, jp], best_w)
        jr = np.argmax(np.sign(v[:, :-1]) * np.sign(v[:, 1:]) <= 0, axis=1)  # first sign change
        peak = kind == _PEAK
        j0 = np.where(peak, np.maximum(jp - 1, 0), jr)
        j1 = np.where(peak, np.minimum(jp + 1, ZOOM_POINTS - 1), jr + 1)
        lo, hi, v_lo, v_hi = w[rows, j0], w[rows, j1], v[rows, j0], v[rows, j1]
    v_lo = np.where(kind == _PEAK, 0.0, v_lo)  # a peak's row has no root: t = 0
    t = np.where(v_lo != v_hi, v_lo / np.where(v_lo != v_hi, v_lo - v_hi, 1.0), 0.0)
    root = np.exp(np.log(lo) + (np.log(hi) - np.log(lo)) * t)
    w = np.where(kind == _PEAK, best_w, root)
    return w, exact(w)


def _phase_crossings(phase: np.ndarray) -> np.ndarray:
    """Fractional indices where the unwrapped ``phase`` (deg) crosses ``-180 + 360 j`` for any ``j``."""
    q = np.floor((phase + 180.0) / 360.0)
    i = np.flatnonzero(q[:-1] != q[1:])
    level = np.maximum(q[i], q[i + 1]) * 360.0 - 180.0
    return i + (level - phase[i]) / (phase[i + 1] - phase[i])


def _wrap(p: np.ndarray) -> np.ndarray:
    return (p + 180.0) % 360.0 - 180.0


def margins(L: np.ndarray, omega: np.ndarray, exact: Callable[[np.ndarray], np.ndarray] | None = None,
            nyquist: float | None = None) -> dict[str, float]:
    """``ms``, ``gm_db``, ``pm_deg`` and the crossover frequencies ``wc_rad_s``, ``w180_rad_s``.

    Parameters
    ----------
    L : (len(omega),) complex
        The loop's response on the grid ``omega`` (rad/s, increasing).
    exact : callable, optional
        ``exact(w) -> L(w)`` at any frequencies (:func:`exact_loop`): the extrema and crossings are refined
        (module docstring); without it, the grid's values.
    nyquist : float, optional
        ``pi / h`` (rad/s): the top of the last grid point's bracket (default: the last grid frequency).
    """
    if not np.all(np.isfinite(L)):
        return {"ms": math.inf, "gm_db": -math.inf, "pm_deg": -math.inf, "wc_rad_s": math.nan,
                "w180_rad_s": math.nan}
    top = float(omega[-1] if nyquist is None else nyquist)
    s = 1.0 / np.abs(1.0 + L)
    logw = np.log10(omega)
    mag_db = 20 * np.log10(np.maximum(np.abs(L), 1e-300))
    phase = np.degrees(np.unwrap(np.angle(L)))
    fc = _crossings(mag_db, 0.0)  # gain crossovers: phase margin 180 + arg L
    pm = _wrap(180.0 + _at(phase, fc))
    f180 = _phase_crossings(phase)  # phase crossovers: gain margin -|L| dB
    gm = -_at(mag_db, f180)
    wc, w180 = 10 ** _at(logw, fc), 10 ** _at(logw, f180)
    ms = float(np.max(s))
    if exact is not None:
        inner = (s[1:-1] >= s[:-2]) & (s[1:-1] >= s[2:])
        peaks = np.r_[[0] if s[0] >= s[1] else [], np.flatnonzero(inner) + 1,
                      [s.size - 1] if s[-1] >= s[-2] else []].astype(int)
        peaks = peaks[np.argsort(-s[peaks], kind="stable")][:N_PEAKS]
        kc = np.argsort(pm, kind="stable")[:N_CROSSINGS]
        k180 = np.argsort(np.abs(gm), kind="stable")[:N_CROSSINGS]
        ic, i180 = np.floor(fc[kc]).astype(int), np.floor(f180[k180]).astype(int)
        lo_p, hi_p = omega[np.maximum(peaks - 1, 0)], np.where(peaks + 1 < omega.size,
                                                               omega[np.minimum(peaks + 1, omega.size - 1)], top)
        # a crossing's bracket is its grid step; it is refined when the exact function changes sign there
        lo_c, hi_c = omega[ic], omega[ic + 1]
        ok_c = np.log(np.abs(L[ic])) * np.log(np.abs(L[ic + 1])) <= 0
        lo_g, hi_g = omega[i180], omega[i180 + 1]
        ok_g = np.angle(-L[i180]) * np.angle(-L[i180 + 1]) <= 0
        kind = np.r_[np.full(peaks.size, _PEAK), np.full(int(ok_c.sum()), _GAIN), np.full(int(ok_g.sum()), _PHASE)]
        if kind.size:
            w, Lw = _zoom(exact, kind, np.r_[lo_p, lo_c[ok_c], lo_g[ok_g]], np.r_[hi_p, hi_c[ok_c], hi_g[ok_g]])
            n0, n1 = peaks.size, peaks.size + int(ok_c.sum())
            if n0:
                ms = max(ms, float(np.max(1.0 / np.abs(1.0 + Lw[:n0]))))
            sel = kc[ok_c]
            pm[sel], wc[sel] = _wrap(180.0 + np.degrees(np.angle(Lw[n0:n1]))), w[n0:n1]
            sel = k180[ok_g]
            gm[sel], w180[sel] = -20.0 * np.log10(np.maximum(np.abs(Lw[n1:]), 1e-300)), w[n1:]
    out = {"ms": ms, "gm_db": math.inf, "pm_deg": math.inf, "wc_rad_s": math.nan, "w180_rad_s": math.nan}
    if pm.size:
        i = int(np.argmin(pm))
        out.update(pm_deg=float(pm[i]), wc_rad_s=float(wc[i]))
    if gm.size:
        i = int(np.argmin(np.abs(gm)))
        out.update(gm_db=float(gm[i]), w180_rad_s=float(w180[i]))
    return out


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
