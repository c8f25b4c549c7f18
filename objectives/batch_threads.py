"""What the population kernels of the filters and the pendulum share (``backend: threads``).

A population kernel evaluates many (candidate, recording) pairs in one ``@njit(parallel=True)`` call:
``prange`` runs over *lanes*, one per thread, and each lane evaluates its pairs one after the other
with the ordinary per-recording kernels, into buffers that belong to the lane (no allocation per
pair, no copy of the recordings, which all threads read). Pairs are dealt to lanes by
:func:`lanes`: longest first, each to the least-loaded lane, so lanes finish together although
recordings differ in length.

Threading layer. GNU OpenMP, numba's default layer where it is installed, kills any process forked
after it ran (``fork() called from a process already using GNU OpenMP``), and the engine forks for
``objective.timeout_s``. :func:`use_threads` therefore selects numba's ``workqueue`` layer (fork-safe;
one parallel call at a time, which is how the engine calls) unless ``NUMBA_THREADING_LAYER`` is set.
"""

from __future__ import annotations

import heapq
import os

import numba
import numpy as np

__all__ = ["use_threads", "lanes"]


def use_threads(n_threads: int) -> int:
    """Prepare numba's thread pool for ``n_threads`` (capped at ``NUMBA_NUM_THREADS``); the lane count."""
    if "NUMBA_THREADING_LAYER" not in os.environ:
        numba.config.THREADING_LAYER = "workqueue"
    n = int(max(1, min(int(n_threads), numba.config.NUMBA_NUM_THREADS)))
    numba.set_num_threads(n)
    return n


def lanes(costs: np.ndarray, n_lanes: int) -> tuple[np.ndarray, np.ndarray]:
    """Deal items of the given costs to ``n_lanes`` lanes, longest first to the least-loaded lane.

    Returns
    -------
    order : (P,) int64
        Item indices grouped by lane (lane 0's items first), each lane's in dealing order.
    start : (n_lanes + 1,) int64
        Lane ``k`` evaluates ``order[start[k]:start[k + 1]]``.
    """
    costs = np.asarray(costs, dtype=float)
    n_lanes = max(1, int(n_lanes))
    heap = [(0.0, k) for k in range(n_lanes)]
    per: list[list[int]] = [[] for _ in range(n_lanes)]
    for i in np.argsort(-costs, kind="stable"):
        load, k = heapq.heappop(heap)
        per[k].append(int(i))
        heapq.heappush(heap, (load + float(costs[i]), k))
    order = np.array([i for lane in per for i in lane], dtype=np.int64)
    start = np.zeros(n_lanes + 1, dtype=np.int64)
    start[1:] = np.cumsum([len(lane) for lane in per])
    return order, start
