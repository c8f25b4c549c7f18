"""Mahony's population kernel (``backend: threads``): every (candidate, recording) pair through
:func:`~objectives.attitude.filters.mahony.kernel.mahony_kernel_inner` in one parallel kernel, the lanes and
the error sums of :mod:`objectives.attitude.batch` around it. Any options, the robust blocks included (a pair
with the blocks off gets the short coefficients and state, zero padded)."""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from objectives.attitude.batch import N_SUMS, Population, claim_pair, pair_sums
from objectives.attitude.filters._bias_filter import S
from objectives.attitude.filters.mahony.kernel import C, mahony_kernel_inner
from objectives.jit import CACHE

__all__ = ["POPULATION"]


@njit(cache=CACHE, parallel=True)
def _population(data, pairs, lanes_, bufs, sums):
    """Mahony on every pair, error sums into ``sums[pair]`` (:func:`objectives.attitude.batch.evaluate_batch`:
    ``data`` its arrays, ``pairs`` ``(rec, use_mag, coefs, states)``, ``bufs`` (lanes, N_max, 4) output and
    conversion buffers)."""
    gyrs, accs, _, trues, masks, rots = data
    coefs, states = pairs[2], pairs[3]
    qbuf, cbuf = bufs
    for lane in prange(qbuf.shape[0]):
        no_bias = np.empty((0, 3))
        no_mag = np.empty((0, 3))
        acc = np.empty(N_SUMS)
        p, r, n, q, mag = claim_pair(lanes_, data, pairs, qbuf, lane, no_mag)
        while p >= 0:
            mahony_kernel_inner(gyrs[r], accs[r], mag, coefs[p], states[p], q, no_bias)
            pair_sums(q, cbuf[lane, :n], rots, r, trues[r], masks[r], acc, sums[p])
            p, r, n, q, mag = claim_pair(lanes_, data, pairs, qbuf, lane, no_mag)


def _run(obj, data, params_list, rows, pairs, lanes_, shape, sums) -> None:
    _population(data.arrays, pairs, lanes_, (np.empty((*shape, 4)), np.empty((*shape, 4))), sums)


#: Mahony's :class:`~objectives.attitude.batch.Population`
POPULATION = Population(_run, coef_len=C.LEN, state_len=S.MAG)
