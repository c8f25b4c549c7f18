"""The statistics of one closed-loop response, computed where it was simulated (numba).

Every (candidate, model, scenario) item of the generic loop ends in one row of statistics
(:func:`_item_stats`): the cost terms of :mod:`.cost`, the mean |.| of each signal ``mae_product`` may
use, and the quantities requirements bound (:mod:`.requirements`). The loop turns rows into costs,
metrics and requirement checks in NumPy; the responses themselves never leave the kernel's buffers, so
a population on many models and scenarios allocates (lanes x samples), not (items x samples).

Definitions (e = r - y of the controlled output, h the period, t = k h, N samples; windows are computed
once per scenario by :func:`windows`):

- IAE = sum |e| h, ISE = sum e^2 h, ITAE = sum t |e| h, ITSE = sum t e^2 h, effort = sum u0^2 h,
  tv = sum |u0[k] - u0[k-1]|; mean |e|, |u0|, |du0/h| (du0[0] = 0), |y_i|, |x_i| over the N samples;
- step (window k0..k1 of the first reference step from r0 to r1, normalised yn = (y - r0) / (r1 - r0)):
  overshoot = 100 max(0, max yn - 1) %, 10-90 % rise time = (first k with yn >= 0.9 - first with
  yn >= 0.1) h (inf if never), 2 % settling time = (last k with |yn - 1| > 0.02, + 1) h from k0 (0 if
  never outside, inf if still outside at the window's end), steady-state error = |r1 - y[k1 - 1]|;
- load (window l0..l1 of the first load step): peak error max |e|;
- signal: peak |u| over every input, and the standard deviation of u0.

Step quantities are NaN without a reference step, the load peak NaN without a load step. The
plain-NumPy reference is ``tests/reference/loop_metrics_reference.py``.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

__all__ = ["STAT_NAMES", "N_FIXED", "stat_size", "windows", "row_metrics"]

#: the fixed part of a statistics row, then mean |y_i| (p values) and mean |x_i| (n values)
STAT_NAMES = ("status", "n_done", "iae", "ise", "itae", "itse", "effort", "tv", "mae_e", "mae_u", "mae_du",
              "overshoot_pct", "rise_time_s", "settling_time_s", "ss_error", "peak_u", "u_std", "load_peak_error")
(S_STATUS, S_DONE, S_IAE, S_ISE, S_ITAE, S_ITSE, S_EFFORT, S_TV, S_MAE_E, S_MAE_U, S_MAE_DU, S_OVERSHOOT, S_RISE,
 S_SETTLE, S_SS, S_PEAK_U, S_U_STD, S_LOAD_PEAK) = range(len(STAT_NAMES))
N_FIXED = len(STAT_NAMES)
#: the window row of a scenario: first reference step k0, k1, r0, r1; first load step l0, l1 (-1: none)
N_WIN = 6


def stat_size(p: int, n: int) -> int:
    """Length of a statistics row for ``p`` outputs and ``n`` states."""
    return N_FIXED + p + n


def windows(r: np.ndarray, load: np.ndarray) -> np.ndarray:
    """``[k0, k1, r0, r1, l0, l1]`` of a scenario's reference ``r`` and load ``load`` (N,).

    The step window starts at the first change of the reference (a step, or a ramp's start; a non-zero
    first sample counts as a step at 0 from 0) and ends (exclusive) at the next change after the
    reference has stopped moving, or at the next change of the load, or at the end. The load window
    starts at the first change of the load (a non-zero first sample counts) and ends at the next change
    of the load or of the reference, or at the end."""
    n = r.size
    out = np.array([-1.0, -1.0, 0.0, 0.0, -1.0, -1.0])
    ch = np.flatnonzero(np.diff(r) != 0) + 1
    if r[0] != 0:
        ch = np.r_[0, ch]
    dl = np.flatnonzero(np.diff(load) != 0) + 1
    if load[0] != 0:
        dl = np.r_[0, dl]
    if ch.size:
        i = 0
        while i + 1 < ch.size and ch[i + 1] == ch[i] + 1:  # a ramp: consecutive changes
            i += 1
        k0, k1 = int(ch[0]), int(ch[i + 1]) if i + 1 < ch.size else n
        later = dl[dl > k0]
        k1 = min(k1, int(later[0])) if later.size else k1
        out[:4] = k0, k1, r[k0 - 1] if k0 > 0 else 0.0, r[k1 - 1]
    if dl.size:
        l0 = int(dl[0])
        nxt = [int(x) for x in (dl[dl > l0][:1].tolist() + ch[ch > l0][:1].tolist())]
        out[4:] = l0, min(nxt) if nxt else n
    return out


@njit(cache=True)
def _item_stats(y, u, x, r, out_idx, h, win, n, status, done, row):
    """The statistics row (module docstring) of the first ``n`` samples of one response into ``row``."""
    p, m, nx = y.shape[1], u.shape[1], x.shape[1]
    row[:] = 0.0
    row[S_STATUS] = status
    row[S_DONE] = done
    iae = ise = itae = itse = eff = tv = mae_e = mae_u = mae_du = 0.0
    peak = 0.0
    u_sum = 0.0
    for k in range(n):
        e = r[k] - y[k, out_idx]
        ae = abs(e)
        t = k * h
        iae += ae
        ise += e * e
        itae += t * ae
        itse += t * e * e
        u0 = u[k, 0]
        eff += u0 * u0
        du = u0 - u[k - 1, 0] if k > 0 else 0.0
        tv += abs(du)
        mae_e += ae
        mae_u += abs(u0)
        mae_du += abs(du / h)
        u_sum += u0
        for j in range(m):
            if abs(u[k, j]) > peak:
                peak = abs(u[k, j])
        for i in range(p):
            row[N_FIXED + i] += abs(y[k, i])
        for i in range(nx):
            row[N_FIXED + p + i] += abs(x[k, i])
    row[S_IAE], row[S_ISE], row[S_ITAE], row[S_ITSE], row[S_EFFORT] = iae * h, ise * h, itae * h, itse * h, eff * h
    row[S_TV], row[S_MAE_E], row[S_MAE_U], row[S_MAE_DU] = tv, mae_e / n, mae_u / n, mae_du / n
    for i in range(p + nx):
        row[N_FIXED + i] /= n
    row[S_PEAK_U] = peak
    mu = u_sum / n
    var = 0.0
    for k in range(n):
        d = u[k, 0] - mu
        var += d * d
    row[S_U_STD] = math.sqrt(var / n)
    # the first reference step
    k0, k1, r0, r1 = int(win[0]), int(win[1]), win[2], win[3]
    step = r1 - r0
    if k0 < 0 or step == 0.0:
        row[S_OVERSHOOT] = row[S_RISE] = row[S_SETTLE] = row[S_SS] = np.nan
    else:
        ymax = -np.inf
        i10 = i90 = -1
        last_out = -1
        for k in range(k0, k1):
            yn = (y[k, out_idx] - r0) / step
            if yn > ymax:
                ymax = yn
            if i10 < 0 and yn >= 0.1:
                i10 = k - k0
            if i90 < 0 and yn >= 0.9:
                i90 = k - k0
            if abs(yn - 1.0) > 0.02:
                last_out = k - k0
        row[S_OVERSHOOT] = max(0.0, ymax - 1.0) * 100.0
        row[S_RISE] = (i90 - i10) * h if i10 >= 0 and i90 >= 0 else np.inf
        if last_out < 0:
            row[S_SETTLE] = 0.0
        elif last_out == k1 - k0 - 1:
            row[S_SETTLE] = np.inf
        else:
            row[S_SETTLE] = (last_out + 1) * h
        row[S_SS] = abs(r1 - y[k1 - 1, out_idx])
    # the first load step
    l0, l1 = int(win[4]), int(win[5])
    if l0 < 0:
        row[S_LOAD_PEAK] = np.nan
    else:
        pk = 0.0
        for k in range(l0, l1):
            e = abs(r[k] - y[k, out_idx])
            if e > pk:
                pk = e
        row[S_LOAD_PEAK] = pk


def row_metrics(row: np.ndarray, p: int, n: int) -> tuple[dict[str, float], dict[str, float], dict[str, float]]:
    """``(terms, means, metrics)`` of a statistics row: the cost terms, the mean |.| of the signals
    ``mae_product`` may name, and the requirement quantities (``overshoot_pct``, ..., ``u_std``)."""
    terms = {k: float(row[i]) for i, k in enumerate(STAT_NAMES) if S_IAE <= i <= S_TV}
    means = {"e": float(row[S_MAE_E]), "u": float(row[S_MAE_U]), "du": float(row[S_MAE_DU]),
             **{f"y{i}": float(row[N_FIXED + i]) for i in range(p)},
             **{f"x{i}": float(row[N_FIXED + p + i]) for i in range(n)}}
    metrics = {k: float(row[i]) for i, k in enumerate(STAT_NAMES) if i >= S_OVERSHOOT}
    return terms, means, metrics
