"""The population driver Madgwick and Mahony share (``backend: threads``): every (candidate, recording) pair
through one filter's kernel body, the lanes and the error sums of :mod:`objectives.attitude.batch` around it.
Any options, the robust blocks included (a pair with the blocks off gets the short coefficients and state,
zero padded).

:func:`population_lanes` is inlined by numba into each filter's own cached parallel kernel, with that filter's
kernel body as ``inner``: the call resolves to the body at compile time, so each filter's kernel compiles its
own body only and runs as when the loop was written out in it (same bits, same speed)."""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from objectives.attitude.batch import N_SUMS, claim_pair, pair_sums

__all__ = ["population_lanes", "run_population"]


@njit(inline="always")
def population_lanes(inner, data, pairs, lanes_, bufs, sums):
    """``inner`` (a kernel body ``(gyr, acc, mag, coefs, state, q_out, bias_out)``) on every pair, error sums
    into ``sums[pair]`` (:func:`objectives.attitude.batch.evaluate_batch`: ``data`` its arrays, ``pairs``
    ``(rec, use_mag, coefs, states)``, ``bufs`` (lanes, N_max, 4) output and conversion buffers)."""
    gyrs, accs, _, trues, masks, rots = data
    coefs, states = pairs[2], pairs[3]
    qbuf, cbuf = bufs
    for lane in prange(qbuf.shape[0]):
        no_bias = np.empty((0, 3))
        no_mag = np.empty((0, 3))
        acc = np.empty(N_SUMS)
        p, r, n, q, mag = claim_pair(lanes_, data, pairs, qbuf, lane, no_mag)
        while p >= 0:
            inner(gyrs[r], accs[r], mag, coefs[p], states[p], q, no_bias)
            pair_sums(q, cbuf[lane, :n], rots, r, trues[r], masks[r], acc, sums[p])
            p, r, n, q, mag = claim_pair(lanes_, data, pairs, qbuf, lane, no_mag)


def run_population(kernel):
    """The :class:`~objectives.attitude.batch.Population` ``run`` hook calling ``kernel(data, pairs, lanes_,
    bufs, sums)`` (a filter's parallel kernel around :func:`population_lanes`) with fresh buffers."""

    def run(obj, data, params_list, rows, pairs, lanes_, shape, sums) -> None:
        kernel(data.arrays, pairs, lanes_, (np.empty((*shape, 4)), np.empty((*shape, 4))), sums)

    return run
