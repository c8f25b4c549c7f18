"""The EKF's and the FAEKF's population kernel (``backend: threads``): every (candidate, recording) pair through
:func:`~objectives.attitude.filters.ekf.kernel.ekf_kernel_inner` (the FAEKF with its fuzzy scale of R first,
eqs. 28-31) in one parallel kernel, the lanes and the error sums of :mod:`objectives.attitude.batch` around it.
Without the robust blocks (a configuration with one on is evaluated serially)."""

from __future__ import annotations

from functools import partial

import numpy as np
from numba import njit, prange

from objectives.attitude.batch import N_SUMS, Population, claim_pair, pair_sums
from objectives.attitude.filters.ekf.fuzzy import faekf_rules, fuzzy_scale_inner
from objectives.attitude.filters.ekf.kernel import C, X, ekf_kernel_inner
from objectives.jit import CACHE

__all__ = ["EKF_POPULATION", "FAEKF_POPULATION"]


@njit(cache=CACHE, parallel=True)
def _population(fuzzy, data, pairs, lanes_, fz, bufs, sums):
    """EKF (``fuzzy`` 0) or FAEKF (1: the fuzzy scale of eqs. 28-31 first) on every pair, error sums into
    ``sums[pair]`` (:func:`objectives.attitude.batch.evaluate_batch`; ``coefs`` (P, C.LEN)).

    fz : ``(vibs, exts, mps, mf_kind, mf_params, rules, cons)``: typed lists of the FAEKF's disturbance
        measures per recording, the (3, 3) set kinds, (P, 3, 3, 4) each pair's membership table, the
        (27, 3) rules and (P, 27) each pair's rule consequents.
    bufs : ``(qbuf, bbuf, cbuf, kbuf)``: per-lane quaternion (lanes, N_max, 4), bias (lanes, N_max, 3),
        converted quaternion and fuzzy-scale (lanes, N_max) buffers.
    """
    gyrs, accs, _, trues, masks, rots = data
    coefs, states = pairs[2], pairs[3]
    vibs, exts, mps, mf_kind, mf_params, rules, cons = fz
    qbuf, bbuf, cbuf, kbuf = bufs
    for lane in prange(qbuf.shape[0]):
        no_mag = np.zeros((1, 3))
        one = np.ones(1)
        acc = np.empty(N_SUMS)
        p, r, n, q, mag = claim_pair(lanes_, data, pairs, qbuf, lane, no_mag)
        while p >= 0:
            if fuzzy != 0:
                k = kbuf[lane, :n]
                fuzzy_scale_inner(vibs[r], exts[r], mps[r], mf_kind, mf_params[p], rules, cons[p], k)
                ekf_kernel_inner(gyrs[r], accs[r], mag, coefs[p], k, states[p], q, bbuf[lane, :n])
            else:
                ekf_kernel_inner(gyrs[r], accs[r], mag, coefs[p], one, states[p], q, bbuf[lane, :n])
            pair_sums(q, cbuf[lane, :n], rots, r, trues[r], masks[r], acc, sums[p])
            p, r, n, q, mag = claim_pair(lanes_, data, pairs, qbuf, lane, no_mag)


def _disturbances(obj, data, flt) -> tuple:
    """The FAEKF's fuzzy inputs per recording (typed lists), the prepared ones its serial path uses."""
    from numba.typed import List  # on use (objectives.attitude.batch)

    outs = ([], [], [])
    prepared = obj.prepare("train")
    for i, rec in enumerate(data.recs):
        d = prepared.disturbances(flt, i)
        d = flt._as_disturbances(rec, d.vib_freq_hz, d.ext_acc_g, d.mag_pert_nu)
        for lst, a in zip(outs, (d.vib_freq_hz, d.ext_acc_g, d.mag_pert_nu)):
            lst.append(a)
    return List(outs[0]), List(outs[1]), List(outs[2])


def _run(fuzzy: bool, obj, data, params_list, rows, pairs, lanes_, shape, sums) -> None:
    """The EKF or (``fuzzy``) the FAEKF on every pair (:func:`_population`), with each pair's fuzzy tables."""
    from numba.typed import List  # on use (objectives.attitude.batch)

    n_lanes, n_max = shape
    P = len(rows)
    mf_kind = np.zeros((3, 3), dtype=np.int64)  # objectives.fuzzy.GAUSS, as FAEKF.scale
    rules = faekf_rules(np.zeros(7))[0]
    mf_params = np.zeros((P, 3, 3, 4))
    cons = np.zeros((P, rules.shape[0]))
    if fuzzy and P:
        flt = obj.make_filter(params_list[rows[0][0]])  # disturbances depend on fixed options only
        vibs, exts, mps = _disturbances(obj, data, flt)
        for k, r in enumerate(rows):
            mf_params[k] = r[5][0]
            cons[k] = r[5][1]
    else:
        vibs = exts = mps = List([np.zeros(0) for _ in data.recs])
    bufs = (np.empty((n_lanes, n_max, 4)), np.empty((n_lanes, n_max, 3)), np.empty((n_lanes, n_max, 4)),
            np.empty((n_lanes, n_max if fuzzy else 0)))
    _population(1 if fuzzy else 0, data.arrays, pairs, lanes_, (vibs, exts, mps, mf_kind, mf_params, rules, cons),
                bufs, sums)


def _fuzzy_tables(flt) -> tuple:
    """The FAEKF's per-candidate tables: set parameters (3, 3, 4), rule consequents (27,), values."""
    return flt.membership_table(), faekf_rules(flt.singletons())[1], flt.values


#: the EKF's :class:`~objectives.attitude.batch.Population` (no robust blocks)
EKF_POPULATION = Population(partial(_run, False), coef_len=C.LEN, state_len=X.LEN, robust=False)
#: the FAEKF's (the fuzzy tables per candidate)
FAEKF_POPULATION = Population(partial(_run, True), coef_len=C.LEN, state_len=X.LEN, robust=False,
                              tables=_fuzzy_tables)
