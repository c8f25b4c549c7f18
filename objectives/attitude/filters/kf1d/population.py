"""The tilt KF's population kernel (``backend: threads``): every (candidate, recording) pair through
:func:`~objectives.attitude.filters.kf1d.kernel.kf1d_kernel_inner`, with the ``mse_1d`` of its angle and the error
sums of its quaternion, in one parallel kernel (lanes and sums of :mod:`objectives.attitude.batch`)."""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from objectives.attitude.batch import N_SUMS, Population, lane_sums, mse_1d_kernel
from objectives.attitude.filters.kf1d.kernel import C, X, kf1d_kernel_inner, quat_from_tilt_inner
from objectives.attitude.filters.kf1d.tilt import up_sign
from objectives.batch_threads import claim
from objectives.jit import CACHE

__all__ = ["POPULATION"]


@njit(cache=CACHE, parallel=True)
def _population(data, pairs, lanes_, bufs, sums, mse):
    """The thesis 1-D tilt KF on every pair: the error sums of its quaternion
    (:func:`~objectives.attitude.filters.kf1d.tilt.quat_from_tilt`, already in the recording's frame) into
    ``sums[pair]`` and the ``mse_1d`` of its angle into ``mse[pair]``.

    data : ``(gys, axs, azs, trues, masks, up, angles)``: per recording the rate about y, the specific force
        along x and z, truth and mask (typed lists), (R,) the kernel's ``up_sign`` and the true angles
        ``mse_1d`` compares with (typed list).
    pairs : ``(rec, coefs, states)``: (P,), (P, C.LEN), (P, X.LEN).
    bufs : ``(bbuf, qbuf, tbuf, ebuf)`` per lane: bias, quaternion, angle and ``mse_1d`` scratch.
    """
    gys, axs, azs, trues, masks, up, angles = data
    pair_rec, coefs, states = pairs
    order, count = lanes_
    bbuf, qbuf, tbuf, ebuf = bufs
    for lane in prange(qbuf.shape[0]):
        one = np.ones(1)
        acc = np.empty(N_SUMS)
        while True:
            j = claim(count)
            if j >= order.shape[0]:
                break
            p = order[j]
            r = pair_rec[p]
            n = gys[r].shape[0]
            th = tbuf[lane, :n]
            kf1d_kernel_inner(gys[r], axs[r], azs[r], up[r], coefs[p], one, states[p], 1, th, bbuf[lane, :n])
            mse[p] = mse_1d_kernel(th, angles[r], masks[r], ebuf[lane])
            q = qbuf[lane, :n]
            quat_from_tilt_inner(th, q)
            lane_sums(q, trues[r], masks[r], acc, sums[p])


def _tilt_inputs(data) -> tuple:
    """The kernel's inputs per recording (gyro y, acc x, acc z, as ``tilt.tilt_inputs``) and each frame's up
    sign, made once per objective like the batch's other arrays (not per generation)."""
    from numba.typed import List  # on use (objectives.attitude.batch)

    c = np.ascontiguousarray
    cols = tuple(List([c(getattr(r, a)[:, k], dtype=np.float64) for r in data.recs])
                 for a, k in (("gyr", 1), ("acc", 0), ("acc", 2)))
    return (*cols, np.array([up_sign(r.frame) for r in data.recs]))


def _run(obj, data, params_list, rows, pairs, lanes_, shape, sums) -> np.ndarray:
    """The tilt KF on every pair (:func:`_population`); returns each pair's ``mse_1d``."""
    n_lanes, n_max = shape
    pair_rec, _, coefs, states = pairs
    mse = np.full(len(rows), np.nan)
    gy, ax, az, up = data.memo("kf1d tilt inputs", lambda: _tilt_inputs(data))
    _population((gy, ax, az, data.trues, data.masks, up, data.angles()), (pair_rec, coefs, states), lanes_,
                (np.empty((n_lanes, n_max)), np.empty((n_lanes, n_max, 4)), np.empty((n_lanes, n_max)),
                 np.empty((n_lanes, n_max))), sums, mse)
    return mse


#: the tilt KF's :class:`~objectives.attitude.batch.Population` (it keeps the angle: ``mse_1d``)
POPULATION = Population(_run, coef_len=C.LEN, state_len=X.LEN, mse_1d=True)
