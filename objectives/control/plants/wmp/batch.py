"""Population evaluation of the pendulum's loop in one numba kernel (``backend: threads``).

:meth:`.loop.WMPLoop.evaluate_batch` (the objective's ``evaluate_batch`` for plant: wmp) comes here. The
Python side builds each candidate's controller parameter array (a design that cannot be built fails as in
the serial path); one ``@njit(parallel=True)`` kernel then runs the closed-loop driver
:func:`objectives.control.plants.wmp.model._simulate` for every candidate, threads sharing the reference
profile and the sensor noise, and scores the run where it was simulated: the error measures of eqs.
2.34-2.35, the means and F of eq. 2.39, the rise times, IB settling time and peaks of
:meth:`.loop.WMPLoop.evaluation`, with the summation order of NumPy
(:func:`objectives.control.plants.wmp.metrics._measures_kernel`). Python only turns each candidate's row of
:data:`_N_STATS` numbers into its :class:`~tuner.objective.Evaluation`, as ``evaluation`` does, so each
result equals what the objective's ``__call__`` returns, bit for bit (tests/control/test_closed_loop_batch.py).

Candidates are claimed by the lanes one at a time (:mod:`objectives.batch_threads`): a robot that falls
early costs little, and the other lane takes the next candidate instead of waiting. The simulation
writes into buffers of its lane, so a batch allocates (lanes x samples), not (candidates x samples).

Cached on disk under rule 3 of :mod:`objectives.jit` (the entry is keyed on the whole package's sources),
and it calls the driver's uncached twin (rule 2), so a new process loads it instead of compiling it.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
from numba import njit, prange

from objectives.batch_threads import _pairwise_sum, claim, counter, use_threads
from objectives.control.design import failed_design
from objectives.control.plants.wmp.metrics import (
    SETTLE_BAND_DEG,
    _measures_kernel,
    _step_window,
    _weighted_cost_kernel,
    cost_exponents,
    first_step,
    log10_product,
)
from objectives.control.plants.wmp.model import STATUS_NAMES, STATUS_OK, _simulate
from objectives.jit import CACHE, uncached
from tuner.objective import Evaluation

__all__ = ["evaluate_batch"]

#: the closed-loop driver as the batch kernel calls it: its uncached twin (rule 2 of objectives.jit)
_simulate_in_kernel = uncached(_simulate)

#: a candidate's row of the kernel's statistics: 4 measures (SAE, SSE, STAE, STSE) of each error ...
_ERRORS = ("nu", "xi", "omega3")
_MEASURES = ("sae", "sse", "stae", "stse")
#: ... then these (rise: the first sample index reaching 90 %, -1 if none; peaks: |.| maxima, NaN if none;
#: settle: samples until the IB angle stays within the band, -1 if the speed reference never steps)
_MAE_NU, _MAE_XI, _MAE_W3, _MS_I, _RISE_NU, _RISE_XI, _PEAK_TH3, _PEAK_I, _COST, _SETTLE = range(12, 22)
_N_STATS = 22


@njit(cache=False)
def _rise_index(y, col, win):
    """First sample ``k - k0`` in the window ``win = (k0, end, r0, r1)`` where ``(y[k, col] - r0) / (r1 - r0)``
    reaches 0.9 (:func:`objectives.control.plants.wmp.metrics.rise_time_s`); -1 if none or ``k0 < 0`` (no step)."""
    k0 = int(win[0])
    if k0 < 0:
        return -1
    for k in range(k0, int(win[1])):
        if (y[k, col] - win[2]) / (win[3] - win[2]) >= 0.9:
            return k - k0
    return -1


@njit(cache=False)
def _settle_count(y, win, band):
    """Samples from the speed step until the IB angle (deg) stays within ``band`` of its value at the end
    of the window ``win = (k0, end, r0, r1)`` (:func:`objectives.control.plants.wmp.metrics.settling_time_s`); -1 if
    ``k0 < 0`` (no step)."""
    k0, end = int(win[0]), int(win[1])
    if k0 < 0:
        return -1
    last = y[end - 1, 1] * (180.0 / np.pi)  # np.degrees
    for k in range(end - 1, k0 - 1, -1):
        if not abs(y[k, 1] * (180.0 / np.pi) - last) <= band:
            return k + 1 - k0
    return 0


@njit(cache=False)
def _abs_nanmax(y, col, n):
    """``np.nanmax(np.abs(y[:n, col]))`` (NaN when every value is NaN)."""
    m = np.nan
    for k in range(n):
        v = abs(y[k, col])
        if v == v and not (v <= m):
            m = v
    return m


@njit(cache=False)
def _score_run(ref, y, ts, wins, expo, e, tmp, out):
    """The statistics row ``out`` (:data:`_N_STATS`) of a complete run: outputs ``y`` (N, 5), references
    ``ref`` (N, 2), as ``WMPLoop.evaluation`` computes them; ``e``, ``tmp``: (N,) scratch."""
    n = ref.shape[0]
    terms = np.empty(4)
    for which in range(3):
        for k in range(n):
            if which == 0:
                e[k] = ref[k, 0] - y[k, 0]
            elif which == 1:
                e[k] = ref[k, 1] - y[k, 3]
            else:
                e[k] = -y[k, 2] * (180.0 / np.pi)  # np.degrees: the measures of e_omega3 are in deg/s
        _measures_kernel(e, ts, tmp, out[4 * which:4 * which + 4])
    out[_MAE_NU] = out[0] / n  # np.mean: the same pairwise sum as SAE, divided by N
    out[_MAE_XI] = out[4] / n
    for k in range(n):
        tmp[k] = abs(-y[k, 2])  # e_omega3 in rad/s for eq. 2.39
    out[_MAE_W3] = _pairwise_sum(tmp, 0, n) / n
    for k in range(n):
        tmp[k] = y[k, 4] * y[k, 4]
    out[_MS_I] = _pairwise_sum(tmp, 0, n) / n
    out[_RISE_NU] = _rise_index(y, 0, wins[0])
    out[_RISE_XI] = _rise_index(y, 3, wins[1])
    out[_SETTLE] = _settle_count(y, wins[0], SETTLE_BAND_DEG)
    for i in range(4):
        terms[i] = out[_MAE_NU + i]
    out[_COST] = _weighted_cost_kernel(terms, expo)


@njit(cache=CACHE, parallel=True)
def _closed_loop_batch(loop, kind, cps, state_size, sched, score, bufs, status, stats):
    """``_simulate`` and its score for every candidate ``p``: controller ``kind`` with parameters ``cps[p]``
    and a zeroed state of ``state_size``; ``status[p]`` is ``(status code, samples done)``, ``stats[p]``
    the statistics row (:data:`_N_STATS`; only the peaks unless the status is ok).

    loop : ``(x0, c, sc, ref, noise, n_sub, fall_limit)``, the arguments of ``_simulate`` every candidate shares.
    sched : ``(order, count)``: the order candidates are claimed in and the claim counter
        (:mod:`objectives.batch_threads`).
    score : ``(ts, wins, expo)``: sample period (s), (2, 4) rise-time windows ``(k0, end, r0, r1)`` of the
        speed and yaw-rate references (k0 = -1: no step), (4,) exponents of eq. 2.39.
    bufs : ``(x_buf, y_buf, m_buf, u_buf, c_buf, e_buf)``: per lane (lanes, N, 8), (lanes, N, 5), (lanes, N, 5),
        (lanes, N, 2), controller state (lanes, state_size) and scratch (lanes, 2, N).
    """
    x0, c, sc, ref, noise, n_sub, fall_limit = loop
    order, count = sched
    ts, wins, expo = score
    x_buf, y_buf, m_buf, u_buf, c_buf, e_buf = bufs
    n_items = order.shape[0]
    for lane in prange(x_buf.shape[0]):
        y = y_buf[lane]
        cs = c_buf[lane]
        while True:
            j = claim(count)
            if j >= n_items:
                break
            p = order[j]
            cs[:] = 0.0
            st, done = _simulate_in_kernel(x0, c, sc, ref, noise, kind, cps[p], cs, n_sub, fall_limit,
                                 x_buf[lane], y, m_buf[lane], u_buf[lane])
            status[p, 0] = st
            status[p, 1] = done
            row = stats[p]
            if st == 0:
                _score_run(ref, y, ts, wins, expo, e_buf[lane, 0], e_buf[lane, 1], row)
            row[_PEAK_TH3] = _abs_nanmax(y, 1, done)
            row[_PEAK_I] = _abs_nanmax(y, 4, done)


def _windows(ref: np.ndarray) -> np.ndarray:
    """(2, 4) rise-time windows ``(k0, end, r0, r1)`` of the speed and yaw-rate references, found as
    ``WMPLoop._rise_time`` and :func:`~objectives.control.plants.wmp.metrics.rise_time_s` find them."""
    wins = np.full((2, 4), -1.0)
    for i in range(2):
        r = ref[:, i]
        k0 = first_step(r)
        if k0 is None:
            continue
        _, _, end = _step_window(r, r, k0)
        wins[i] = (k0, end, float(r[k0 - 1]) if k0 > 0 else 0.0, float(r[k0]))
    return wins


def _evaluation(obj: Any, st: int, done: int, s: np.ndarray, wins: np.ndarray) -> Evaluation:
    """``obj.evaluation`` of a run from its status and statistics row ``s``."""
    ts = obj._sensors.Ts_s
    peak = {
        "peak_theta3_deg": float(np.degrees(s[_PEAK_TH3])) if done else 0.0,
        "peak_current_A": float(s[_PEAK_I]) if done else 0.0,
        "status_code": float(st),
    }
    if st != STATUS_OK:
        return Evaluation.failed(f"robot {STATUS_NAMES[st]} at t={done * ts:.2f} s", peak)
    metrics: dict[str, float] = {}
    for m, measure in enumerate(_MEASURES):  # the keys and order of metrics.error_integrals
        vals = []
        for e, name in enumerate(_ERRORS):
            metrics[f"{measure}_{name}"] = float(s[4 * e + m])
            vals.append(metrics[f"{measure}_{name}"])
        metrics[f"{measure}_log10_prod"] = log10_product(vals)
    rise = [float(int(s[k])) * ts if s[k] >= 0 else (math.inf if wins[i, 0] >= 0 else math.nan)
            for i, k in enumerate((_RISE_NU, _RISE_XI))]
    metrics.update({"mae_nu": float(s[_MAE_NU]), "mae_xi": float(s[_MAE_XI]), "mae_omega3": float(s[_MAE_W3]),
                    "ms_current": float(s[_MS_I]), "rise_time_nu_s": rise[0], "rise_time_xi_s": rise[1],
                    "settle_theta3_s": float(int(s[_SETTLE])) * ts if s[_SETTLE] >= 0 else math.nan})
    metrics.update(peak)
    return obj.scored(float(s[_COST]), metrics)


def evaluate_batch(obj: Any, params_list: Sequence[Mapping[str, Any]], n_threads: int) -> list[Any]:
    """Evaluations of ``params_list`` equal to ``[obj(p) for p in params_list]``.

    An item is the :class:`~tuner.objective.Evaluation` or the exception the serial call raises.
    """
    results: list[Any] = [None] * len(params_list)
    rows: list[tuple[int, np.ndarray]] = []
    for i, params in enumerate(params_list):
        values = dict(obj.fixed)
        values.update(params or {})
        try:
            cp = np.ascontiguousarray(obj.ctrl.param_array(values), dtype=float)
        except ValueError as exc:  # as ClosedLoopObjective.__call__: a design that cannot be built
            results[i] = failed_design(exc)
            continue
        except Exception as exc:
            results[i] = exc
            continue
        rows.append((i, cp))
    n_lanes = use_threads(n_threads)
    ref = np.ascontiguousarray(obj._ref, dtype=float)
    n, P = ref.shape[0], len(rows)
    width = max([len(cp) for _, cp in rows] or [1])
    cps = np.zeros((P, width))
    for k, (_, cp) in enumerate(rows):
        cps[k, :len(cp)] = cp
    lanes = max(1, min(n_lanes, P))
    state_size = int(obj._cls.state_size)
    bufs = (np.full((lanes, n, 8), np.nan), np.full((lanes, n, 5), np.nan), np.full((lanes, n, 5), np.nan),
            np.full((lanes, n, 2), np.nan), np.zeros((lanes, state_size)), np.empty((lanes, 2, n)))
    status = np.zeros((P, 2), dtype=np.int64)
    stats = np.full((P, _N_STATS), np.nan)
    wins = _windows(ref)
    loop = (np.zeros(8), obj._params.coeffs(), obj._sensors.coeffs(obj._params.u_max_V), ref,
            np.ascontiguousarray(obj._noise, dtype=float), int(obj.n_sub), math.radians(obj.fall_limit_deg))
    sched = (np.arange(P, dtype=np.int64), counter())  # no cost is known before the run: claiming balances
    score = (float(obj._sensors.Ts_s), wins, cost_exponents(obj.cost))
    _closed_loop_batch(loop, int(obj._cls.kind), cps, state_size, sched, score, bufs, status, stats)
    for k, (i, _) in enumerate(rows):
        try:
            results[i] = _evaluation(obj, int(status[k, 0]), int(status[k, 1]), stats[k], wins)
        except Exception as exc:
            results[i] = exc
    return results
