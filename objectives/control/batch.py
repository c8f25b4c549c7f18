"""Population evaluation of the closed-loop objective in one numba kernel (``backend: threads``).

:meth:`ClosedLoopObjective.evaluate_batch` comes here. The Python side builds each candidate's
controller parameter array (a design that cannot be built fails as in the serial path); one
``@njit(parallel=True)`` kernel then runs the closed-loop driver :func:`objectives.control.wmp._simulate`
for every candidate, threads sharing the reference profile and the sensor noise, candidates dealt to
lanes (:mod:`objectives.batch_threads`). The responses are scored by the objective's own
``_evaluation``, so each result equals what ``__call__`` returns, bit for bit
(tests/control/test_closed_loop_batch.py).

Not cached (``cache=False``), like the driver it calls (see :mod:`objectives.control.wmp`): the kernel
compiles once per process, on the first batch.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
from numba import njit, prange

from objectives.batch_threads import lanes, use_threads
from objectives.control.wmp import STATUS_NAMES, _simulate
from tuner.objective import Evaluation

__all__ = ["evaluate_batch"]


@njit(cache=False, parallel=True)
def _closed_loop_batch(loop, kind, cps, state_size, lanes_, outs, status):
    """``_simulate`` for every candidate ``p``: controller ``kind`` with parameters ``cps[p]`` and a zeroed
    state of ``state_size``; ``status[p]`` is ``(status code, samples done)``.

    loop : ``(x0, c, sc, ref, noise, n_sub, fall_limit)``, the arguments of ``_simulate`` every candidate shares.
    lanes_ : ``(order, start)`` (objectives.batch_threads.lanes).
    outs : ``(x_out, y_out, m_out, u_out)``: (P, N, 8), (P, N, 5), (P, N, 5), (P, N, 2), NaN-filled.
    """
    x0, c, sc, ref, noise, n_sub, fall_limit = loop
    order, start = lanes_
    x_out, y_out, m_out, u_out = outs
    for lane in prange(start.shape[0] - 1):
        for j in range(start[lane], start[lane + 1]):
            p = order[j]
            cs = np.zeros(state_size)
            st, done = _simulate(x0, c, sc, ref, noise, kind, cps[p], cs, n_sub, fall_limit,
                                 x_out[p], y_out[p], m_out[p], u_out[p])
            status[p, 0] = st
            status[p, 1] = done


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
            cp = np.ascontiguousarray(obj._ctrl.param_array(values), dtype=float)
        except ValueError as exc:  # as ClosedLoopObjective.__call__: a design that cannot be built
            results[i] = Evaluation.failed(f"controller design failed: {exc}")
            continue
        except Exception as exc:
            results[i] = exc
            continue
        rows.append((i, cp))
    n_lanes = use_threads(n_threads)
    ref, noise = obj._ref, obj._noise
    n, P = ref.shape[0], len(rows)
    width = max([len(cp) for _, cp in rows] or [1])
    cps = np.zeros((P, width))
    for k, (_, cp) in enumerate(rows):
        cps[k, :len(cp)] = cp
    x_out = np.full((P, n, 8), np.nan)
    y_out = np.full((P, n, 5), np.nan)
    m_out = np.full((P, n, 5), np.nan)
    u_out = np.full((P, n, 2), np.nan)
    status = np.zeros((P, 2), dtype=np.int64)
    order, start = lanes(np.ones(P), n_lanes)
    loop = (np.zeros(8), obj._plant.coeffs(), obj._sensors.coeffs(obj._plant.u_max_V),
            np.ascontiguousarray(ref, dtype=float), np.ascontiguousarray(noise, dtype=float), int(obj.n_sub),
            math.radians(obj.fall_limit_deg))
    _closed_loop_batch(loop, int(obj._cls.kind), cps, int(obj._cls.state_size), (order, start),
                       (x_out, y_out, m_out, u_out), status)
    for k, (i, _) in enumerate(rows):
        st = int(status[k, 0])
        sim = {"outputs": y_out[k], "references": ref, "n_done": int(status[k, 1]), "status": st,
               "status_name": STATUS_NAMES[st], "state": x_out[k], "measurements": m_out[k], "voltages": u_out[k]}
        try:
            results[i] = obj._evaluation(sim)
        except Exception as exc:
            results[i] = exc
    return results
