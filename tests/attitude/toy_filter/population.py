"""The toy filter's population kernel: the lane machinery of :mod:`objectives.attitude.batch` around its kernel."""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from objectives.attitude.batch import N_SUMS, Population, claim_pair, pair_sums
from tests.attitude.toy_filter.kernel import C, X, toy_kernel


@njit(parallel=True)
def _population(data, pairs, lanes_, bufs, sums):
    gyrs, accs, _, trues, masks, rots = data
    coefs, states = pairs[2], pairs[3]
    qbuf, cbuf = bufs
    for lane in prange(qbuf.shape[0]):
        no_mag = np.empty((0, 3))
        acc = np.empty(N_SUMS)
        p, r, n, q, mag = claim_pair(lanes_, data, pairs, qbuf, lane, no_mag)
        while p >= 0:
            toy_kernel(gyrs[r], accs[r], coefs[p], states[p], q)
            pair_sums(q, cbuf[lane, :n], rots, r, trues[r], masks[r], acc, sums[p])
            p, r, n, q, mag = claim_pair(lanes_, data, pairs, qbuf, lane, no_mag)


def _run(obj, data, params_list, rows, pairs, lanes_, shape, sums) -> None:
    _population(data.arrays, pairs, lanes_, (np.empty((*shape, 4)), np.empty((*shape, 4))), sums)


POPULATION = Population(_run, coef_len=C.LEN, state_len=X.LEN)
