"""What the population kernels of the filters and the pendulum share (``backend: threads``).

A population kernel evaluates many items (a (candidate, recording) pair, or a candidate of the
pendulum) in one ``@njit(parallel=True)`` call: ``prange`` runs over *lanes*, one per thread, and each
lane evaluates items one after the other with the ordinary per-recording kernels, into buffers that
belong to the lane (no allocation per item, no copy of the recordings, which all threads read).

Dynamic dealing. A lane takes the next item of :func:`deal`'s order (longest first) when it is free,
by an atomic fetch-and-add on a shared counter (:func:`claim`), so lanes finish together whatever the
items really cost: a pendulum that falls after 0.3 s costs a tenth of one that runs the whole profile,
which no prediction knows before the run, and a lane whose core another process holds for a while
takes fewer items. Which lane evaluates an item changes nothing in its result (each item writes only
its own output row and overwrites the lane's buffers before reading them), so results stay equal to
the serial path's bit for bit.

Threading layer. GNU OpenMP, numba's default layer where it is installed, kills any process forked
after it ran (``fork() called from a process already using GNU OpenMP``), and the engine forks for
``objective.timeout_s``. :func:`use_threads` therefore selects numba's ``workqueue`` layer (fork-safe;
one parallel call at a time, which is how the engine calls) unless ``NUMBA_THREADING_LAYER`` is set.
``workqueue`` splits a ``prange`` statically into one block per thread; the lanes' claiming makes the
work inside them dynamic.

Scoring inside the kernels. Where a kernel scores an item itself (instead of handing the samples back
to NumPy code), its sums must be NumPy's to stay bit-identical to the serial path:
:func:`_pairwise_sum` adds in ``np.sum``'s order.
"""

from __future__ import annotations

import os

import numba
import numpy as np
from numba import njit, types
from numba.core import cgutils
from numba.extending import intrinsic

__all__ = ["use_threads", "deal", "claim", "counter"]


def use_threads(n_threads: int) -> int:
    """Prepare numba's thread pool for ``n_threads`` (capped at ``NUMBA_NUM_THREADS``); the lane count."""
    if "NUMBA_THREADING_LAYER" not in os.environ:
        numba.config.THREADING_LAYER = "workqueue"
    n = int(max(1, min(int(n_threads), numba.config.NUMBA_NUM_THREADS)))
    numba.set_num_threads(n)
    return n


def deal(costs: np.ndarray) -> np.ndarray:
    """The order in which lanes claim items: by predicted cost, longest first (ties in index order).

    Longest first keeps the tail short: the last items taken are the cheapest, so the lane that
    finishes last waits for little (the longest-processing-time rule).
    """
    costs = np.asarray(costs, dtype=float)
    return np.argsort(-costs, kind="stable").astype(np.int64)


def counter() -> np.ndarray:
    """A fresh shared counter for :func:`claim` (one per kernel call)."""
    return np.zeros(1, dtype=np.int64)


@intrinsic
def claim(typingctx, count):
    """In a kernel: atomically ``count[0] += 1`` and the value before (the index of the claimed item).

    Sequentially consistent ``atomicrmw add`` on the counter's first element, so every index is
    handed out exactly once, whichever thread asks.
    """
    if not (isinstance(count, types.Array) and count.dtype == types.int64 and count.ndim == 1):
        return None
    sig = types.int64(count)

    def codegen(context, builder, signature, args):
        aryty = signature.args[0]
        ary = context.make_array(aryty)(context, builder, args[0])
        ptr = cgutils.get_item_pointer(context, builder, aryty, ary, [context.get_constant(types.intp, 0)])
        return builder.atomic_rmw("add", ptr, context.get_constant(types.int64, 1), "seq_cst")

    return sig, codegen


@njit
def _block_sum(a, lo, n):
    """NumPy's sum of at most 128 values ``a[lo:lo + n]`` (one leaf of :func:`_pairwise_sum`)."""
    if n < 8:
        res = -0.0  # NumPy's initial value of a non-empty float sum (keeps the sign of sum([-0.0]))
        for i in range(lo, lo + n):
            res += a[i]
        return res
    r0, r1, r2, r3 = a[lo], a[lo + 1], a[lo + 2], a[lo + 3]
    r4, r5, r6, r7 = a[lo + 4], a[lo + 5], a[lo + 6], a[lo + 7]
    i = lo + 8
    stop = lo + n - n % 8
    while i < stop:
        r0 += a[i]
        r1 += a[i + 1]
        r2 += a[i + 2]
        r3 += a[i + 3]
        r4 += a[i + 4]
        r5 += a[i + 5]
        r6 += a[i + 6]
        r7 += a[i + 7]
        i += 8
    res = ((r0 + r1) + (r2 + r3)) + ((r4 + r5) + (r6 + r7))
    while i < lo + n:
        res += a[i]
        i += 1
    return res


@njit
def _pairwise_sum(a, lo, n):
    """``np.sum(a[lo:lo + n])`` of a float64 array, bit for bit: NumPy's pairwise summation.

    NumPy (``@TYPE@_pairwise_sum``, numpy/_core/src/umath/loops_utils.h.src) adds fewer than 8 values
    in a row, up to 128 with eight interleaved accumulators combined as ((0+1)+(2+3))+((4+5)+(6+7)) and
    the rest added in a row, and splits longer ranges in two halves cut at a multiple of 8, summing
    each half the same way. The halving is walked here with an explicit stack (a recursive kernel
    cannot be linked into the parallel kernels that call this one).
    """
    if n <= 128:
        return _block_sum(a, lo, n)
    f_lo = np.empty(64, dtype=np.int64)  # frames: range start, length, stage (0 new, 1 left pending,
    f_n = np.empty(64, dtype=np.int64)  # 2 right pending) and the left half's sum
    f_stage = np.empty(64, dtype=np.int64)
    f_left = np.empty(64)
    depth = 0
    f_lo[0], f_n[0], f_stage[0] = lo, n, 0
    have, ret = False, 0.0
    while True:
        if have:  # ret is the sum of a child of frame `depth`
            if depth < 0:
                return ret
            if f_stage[depth] == 1:
                f_left[depth] = ret
                f_stage[depth] = 2
                half = f_n[depth] // 2
                half -= half % 8
                depth += 1
                f_lo[depth], f_n[depth], f_stage[depth] = f_lo[depth - 1] + half, f_n[depth - 1] - half, 0
                have = False
            else:
                ret = f_left[depth] + ret
                depth -= 1
            continue
        m = f_n[depth]
        if m <= 128:
            ret = _block_sum(a, f_lo[depth], m)
            depth -= 1
            have = True
            continue
        half = m // 2
        half -= half % 8
        f_stage[depth] = 1
        depth += 1
        f_lo[depth], f_n[depth], f_stage[depth] = f_lo[depth - 1], half, 0
