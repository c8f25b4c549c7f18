"""The QUKF's and the QRAUKF's population kernel (``backend: threads``): every (candidate, recording) pair
through :func:`~objectives.attitude.filters.ukf.kernel._ukf_run_inner` in one parallel kernel, the lanes and the
error sums of :mod:`objectives.attitude.batch` around it. Without the robust blocks (a configuration with one on
is evaluated serially)."""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from objectives.attitude.batch import N_SUMS, Population, claim_pair, pair_sums
from objectives.attitude.filters.ukf.kernel import N_STATE_FIXED, WORK_SIZE, C, I, _ukf_run_inner
from objectives.jit import CACHE

__all__ = ["POPULATION"]


@njit(cache=CACHE, parallel=True)
def _population(data, pairs, istates, lanes_, bufs, sums):
    """QUKF / QRAUKF (``coefs[p, C.ROBUST]``) on every pair, error sums into ``sums[pair]``
    (:func:`objectives.attitude.batch.evaluate_batch`; ``coefs`` (P, C.LEN), ``states`` padded to the longest
    innovation window); ``istates`` (P, I.LEN) the integer start states; ``bufs``: per-lane quaternion, converted
    quaternion, bias, Hampel gain, skipped and fallback buffers."""
    gyrs, accs, _, trues, masks, rots = data
    coefs, states = pairs[2], pairs[3]
    qbuf, cbuf, bbuf, lbuf, sbuf, fbuf = bufs
    for lane in prange(qbuf.shape[0]):
        no_mag = np.empty((0, 3))
        work = np.empty(WORK_SIZE)
        acc = np.empty(N_SUMS)
        p, r, n, q, mag = claim_pair(lanes_, data, pairs, qbuf, lane, no_mag)
        while p >= 0:
            work[:] = 0.0  # the serial run's fresh scratch
            _ukf_run_inner(gyrs[r], accs[r], mag, coefs[p], coefs[p, C.ROBUST] != 0.0, states[p], istates[p], work,
                           q, bbuf[lane, :n], lbuf[lane, :n], sbuf[lane, :n], fbuf[lane, :n])
            pair_sums(q, cbuf[lane, :n], rots, r, trues[r], masks[r], acc, sums[p])
            p, r, n, q, mag = claim_pair(lanes_, data, pairs, qbuf, lane, no_mag)


def _run(obj, data, params_list, rows, pairs, lanes_, shape, sums) -> None:
    """The QUKF / QRAUKF on every pair (:func:`_population`), each from its setup's integer state."""
    n_lanes, n_max = shape
    istates = np.array([r[6][0] for r in rows], dtype=np.int64).reshape(len(rows), I.LEN)
    flags = np.zeros((n_lanes, n_max), dtype=np.bool_)
    _population(data.arrays, pairs, istates, lanes_, (np.empty((n_lanes, n_max, 4)), np.empty((n_lanes, n_max, 4)),
                                                      np.empty((n_lanes, n_max, 3)), np.empty((n_lanes, n_max, 3)),
                                                      flags, flags.copy()), sums)


#: the UKFs' :class:`~objectives.attitude.batch.Population` (no robust blocks; a window of 1 without pairs)
POPULATION = Population(_run, coef_len=C.LEN, state_len=N_STATE_FIXED + 6, robust=False)
