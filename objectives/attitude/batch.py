"""Population evaluation of the filter objective in one numba kernel (``backend: threads``).

:meth:`FilterObjective.evaluate_batch` comes here. For every (candidate, recording) pair the Python
side builds what the serial path would hand the filter kernel (the validated filter, its coefficient
array, the initial state, the FAEKF's fuzzy tables); one ``@njit(parallel=True)`` kernel then runs,
for every pair, the filter's own per-recording kernel, the frame conversion of
:func:`objectives.attitude.quaternion.to_frame` and the one-pass error sums of
:mod:`objectives.attitude.fused_errors`, threads sharing the recordings (see
:mod:`objectives.batch_threads` for lanes, dynamic claiming and buffers). The sums are combined per candidate by the
objective's own code (``_combine`` and ``_evaluation``), so each result equals what ``__call__``
returns for the same parameters, bit for bit (tests/attitude/test_filter_batch.py).

A filter class names the population kernel that runs it in its own ``batch_kernel`` (a key of
:data:`_KERNELS`; a subclass, which may change ``_run``, declares its own), and every pair starts from the
filter's :meth:`~objectives.attitude.filters.base.AttitudeFilter.kernel_setup`, as its serial run does.
Batched: Madgwick and Mahony (any options), EKF / FAEKF and QUKF / QRAUKF without the robust blocks and the
thesis 1-D KF (``kf1d``, the only one with ``mse_1d``: its angle is kept per pair), on recordings that all
have truth, without ``heading_offset: remove`` (its truth depends on each candidate's output). For any other
configuration :func:`evaluate_batch` returns None and the engine evaluates
serially.

The population kernels call kernels of other modules and are cached on disk under rule 3 of
:mod:`objectives.jit` (each entry keyed on the whole package's sources): they compile once per machine,
not in every process on its first batch (15 s for Madgwick's); their callees are compiled into them
(rule 2).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from functools import partial
from typing import Any

import numpy as np
from numba import njit, prange
from numba.typed import List

from objectives.attitude.divergence import N_SEGMENTS, _segment_ms_inner, growth_verdict, recording_failure
from objectives.attitude.filters._ekf_kernel import ekf_kernel_inner
from objectives.attitude.filters._kf1d_kernels import kf1d_kernel_inner
from objectives.attitude.filters._ukf_kernels import WORK_SIZE, _ukf_run_inner
from objectives.attitude.filters.base import initial_quaternion
from objectives.attitude.filters.ekf import faekf_rules, fuzzy_scale_inner, gravity_in_units
from objectives.attitude.filters.kf1d import _quat_from_tilt_inner, _up_sign
from objectives.attitude.filters.madgwick import _madgwick_kernel_inner
from objectives.attitude.filters.mahony import _mahony_kernel_inner
from objectives.attitude.fused_errors import ErrorSums, _error_sums_inner
from objectives.attitude.quaternion import euler_zyx
from objectives.attitude.quaternion.algebra import _qmul_kernel_inner
from objectives.attitude.quaternion.conversions import frame_rotation
from objectives.batch_threads import _pairwise_sum, claim, counter, deal, use_threads
from objectives.jit import CACHE
from tuner.objective import Score

__all__ = ["evaluate_batch", "batchable"]

#: per pair: the 11 error sums of fused_errors, then the N_SEGMENTS mean squares and counts of divergence
_N_ERR = 11
_N_SUMS = _N_ERR + 2 * N_SEGMENTS


@njit(cache=False)
def _pair_sums(q, c, rots, r, true, mask, acc, out):
    """Error sums and growth segments (``out``, :data:`_N_SUMS`) of the estimate ``q`` of recording ``r``
    (converted into ``c`` to its frame if needed), accumulated in the lane's own ``acc`` (see
    :func:`_lane_sums`)."""
    if rots[r, 4] != 0.0:
        _qmul_kernel_inner(rots[r:r + 1, :4], q, c)
        q = c
    _lane_sums(q, true, mask, acc, out)


@njit(cache=False)
def _lane_sums(q, true, mask, acc, out):
    """The error sums and growth segments of ``q`` into ``out``, accumulated per sample in ``acc`` (the
    lane's (:data:`_N_SUMS`,) array) and copied once: rows of ``sums`` that two lanes fill at the same
    time can share a cache line, which per-sample updates would pass between the cores all the time."""
    _error_sums_inner(q, true, mask, acc[:_N_ERR])
    _segment_ms_inner(q, true, mask, acc[_N_ERR:])
    out[:] = acc


@njit(cache=False, inline="always")
def _claim_pair(lanes_, data, pairs, qbuf, lane, no_mag):
    """The next pair the lane claims (:mod:`objectives.batch_threads`): pair, recording, length, the lane's
    output view and the magnetometer it uses; pair -1 once every pair is claimed."""
    order, count = lanes_
    j = claim(count)
    if j >= order.shape[0]:
        return -1, 0, 0, qbuf[lane, :0], no_mag
    p = order[j]
    r = pairs[0][p]
    n = data[0][r].shape[0]
    mag = data[2][r] if pairs[1][p] != 0 else no_mag
    return p, r, n, qbuf[lane, :n], mag


@njit(cache=CACHE, parallel=True)
def _bias_batch(family, data, pairs, lanes_, bufs, sums):
    """Madgwick (family 0) or Mahony (1) on every pair, error sums into ``sums[pair]`` (P, 11).

    data : ``(gyrs, accs, mags, trues, masks, rots)``: typed lists, one array per recording (``mags[r]``
        (0, 3) without one), and ``rots`` (R, 5): the rotation quaternion to the recording's frame and
        1.0 when a conversion is needed.
    pairs : ``(rec, use_mag, coefs, states)``: (P,) recording of each pair, 1 when it uses the
        magnetometer, (P, 5) coefficients (Mahony's 4 padded with a zero) and (P, 7) initial states, or
        (P, COEF_LEN) and (P, STATE_LEN) when a pair has the robust blocks on (zero padding keeps them off).
    lanes_ : ``(order, count)``: the order pairs are claimed in and the claim counter
        (:mod:`objectives.batch_threads`).
    bufs : ``(qbuf, cbuf)``: (lanes, N_max, 4) per-lane output buffers.
    """
    gyrs, accs, _, trues, masks, rots = data
    coefs, states = pairs[2], pairs[3]
    qbuf, cbuf = bufs
    for lane in prange(qbuf.shape[0]):
        no_bias = np.empty((0, 3))
        no_mag = np.empty((0, 3))
        acc = np.empty(_N_SUMS)
        p, r, n, q, mag = _claim_pair(lanes_, data, pairs, qbuf, lane, no_mag)
        while p >= 0:
            if family == 0:
                _madgwick_kernel_inner(gyrs[r], accs[r], mag, coefs[p], states[p], q, no_bias)
            else:
                _mahony_kernel_inner(gyrs[r], accs[r], mag, coefs[p], states[p], q, no_bias)
            _pair_sums(q, cbuf[lane, :n], rots, r, trues[r], masks[r], acc, sums[p])
            p, r, n, q, mag = _claim_pair(lanes_, data, pairs, qbuf, lane, no_mag)


@njit(cache=CACHE, parallel=True)
def _ekf_batch(fuzzy, data, pairs, lanes_, fz, bufs, sums):
    """EKF (``fuzzy`` 0) or FAEKF (1: the fuzzy scale of eqs. 28-31 first) on every pair, as ``_bias_batch``
    (``coefs`` (P, 12)).

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
        acc = np.empty(_N_SUMS)
        p, r, n, q, mag = _claim_pair(lanes_, data, pairs, qbuf, lane, no_mag)
        while p >= 0:
            if fuzzy != 0:
                k = kbuf[lane, :n]
                fuzzy_scale_inner(vibs[r], exts[r], mps[r], mf_kind, mf_params[p], rules, cons[p], k)
                ekf_kernel_inner(gyrs[r], accs[r], mag, coefs[p], k, states[p], q, bbuf[lane, :n])
            else:
                ekf_kernel_inner(gyrs[r], accs[r], mag, coefs[p], one, states[p], q, bbuf[lane, :n])
            _pair_sums(q, cbuf[lane, :n], rots, r, trues[r], masks[r], acc, sums[p])
            p, r, n, q, mag = _claim_pair(lanes_, data, pairs, qbuf, lane, no_mag)


@njit(cache=CACHE, parallel=True)
def _ukf_batch(data, pairs, istates, lanes_, bufs, sums):
    """QUKF / QRAUKF (``coefs[p, 7]``) on every pair, as ``_bias_batch`` (``coefs`` (P, 8), ``states`` padded to
    the longest innovation window); ``istates`` (P, 4) the integer start states; ``bufs``: per-lane quaternion,
    converted quaternion, bias, Hampel gain, skipped and fallback buffers."""
    gyrs, accs, _, trues, masks, rots = data
    coefs, states = pairs[2], pairs[3]
    qbuf, cbuf, bbuf, lbuf, sbuf, fbuf = bufs
    for lane in prange(qbuf.shape[0]):
        no_mag = np.empty((0, 3))
        work = np.empty(WORK_SIZE)
        acc = np.empty(_N_SUMS)
        p, r, n, q, mag = _claim_pair(lanes_, data, pairs, qbuf, lane, no_mag)
        while p >= 0:
            work[:] = 0.0  # the serial run's fresh scratch
            _ukf_run_inner(gyrs[r], accs[r], mag, coefs[p], coefs[p, 7] != 0.0, states[p], istates[p], work, q,
                           bbuf[lane, :n], lbuf[lane, :n], sbuf[lane, :n], fbuf[lane, :n])
            _pair_sums(q, cbuf[lane, :n], rots, r, trues[r], masks[r], acc, sums[p])
            p, r, n, q, mag = _claim_pair(lanes_, data, pairs, qbuf, lane, no_mag)


@njit(cache=False)
def _wrap_angle(a):
    """:func:`objectives.attitude.metrics.wrap_angle` of one value, bit for bit (``np.mod``'s rules)."""
    two_pi = 2.0 * np.pi
    out = (a + np.pi) % two_pi - np.pi  # Python's float % has np.mod's rules (fmod, then the divisor's sign)
    return out - two_pi if out >= np.pi else out


@njit(cache=False)
def _mse_1d_kernel(est, true, mask, e):
    """:func:`objectives.attitude.metrics.mse_1d` of ``est`` against ``true`` inside ``mask``, bit for bit
    (NumPy's pairwise mean over the valid samples, gathered into the scratch ``e``); NaN if none is valid."""
    m = 0
    for k in range(true.shape[0]):
        if math.isfinite(true[k]) and mask[k]:
            w = _wrap_angle(true[k] - est[k]) if math.isfinite(est[k]) else np.pi
            e[m] = w * w
            m += 1
    if m == 0:
        return np.nan
    return _pairwise_sum(e, 0, m) / m


@njit(cache=CACHE, parallel=True)
def _kf1d_batch(data, pairs, lanes_, bufs, sums, mse):
    """The thesis 1-D tilt KF on every pair: the error sums of its quaternion
    (:func:`objectives.attitude.filters.kf1d.quat_from_tilt`, already in the recording's frame) into
    ``sums[pair]`` and the ``mse_1d`` of its angle into ``mse[pair]``.

    data : ``(gys, axs, azs, trues, masks, up, angles)``: per recording the rate about y, the specific force
        along x and z, truth and mask (typed lists), (R,) the kernel's ``up_sign`` and the true angles
        ``mse_1d`` compares with (typed list).
    pairs : ``(rec, coefs, states)``: (P,), (P, 4), (P, 5).
    bufs : ``(bbuf, qbuf, tbuf, ebuf)`` per lane: bias, quaternion, angle and ``mse_1d`` scratch.
    """
    gys, axs, azs, trues, masks, up, angles = data
    pair_rec, coefs, states = pairs
    order, count = lanes_
    bbuf, qbuf, tbuf, ebuf = bufs
    for lane in prange(qbuf.shape[0]):
        one = np.ones(1)
        acc = np.empty(_N_SUMS)
        while True:
            j = claim(count)
            if j >= order.shape[0]:
                break
            p = order[j]
            r = pair_rec[p]
            n = gys[r].shape[0]
            th = tbuf[lane, :n]
            kf1d_kernel_inner(gys[r], axs[r], azs[r], up[r], coefs[p], one, states[p], 1, th, bbuf[lane, :n])
            mse[p] = _mse_1d_kernel(th, angles[r], masks[r], ebuf[lane])
            q = qbuf[lane, :n]
            _quat_from_tilt_inner(th, q)
            _lane_sums(q, trues[r], masks[r], acc, sums[p])


def _kernel(obj: Any) -> _Kernel | None:
    """The population kernel the objective's filter class declares (``batch_kernel`` of the class itself)."""
    return _KERNELS.get(vars(obj._cls).get("batch_kernel"))


def batchable(obj: Any) -> bool:
    """True when :func:`evaluate_batch` can evaluate this objective's configuration (module docstring)."""
    kernel = _kernel(obj)
    if kernel is None or (obj.metric == "mse_1d" and not kernel.mse_1d):
        return False
    if obj.metric_options.get("heading_offset") == "remove":  # the truth depends on each candidate's output
        return False
    if not kernel.robust:
        try:
            if obj.make_filter({}).robust:
                return False
        except ValueError:
            return False
    recs = obj.recordings("train")
    return bool(recs) and all(rec.quat is not None for rec in recs)


class _Data:
    """The recordings as the kernels read them (built once per objective, shared by every batch)."""

    def __init__(self, obj: Any):
        recs = obj.prepare("train").recordings
        self.recs = recs
        c = np.ascontiguousarray
        self.gyrs = List([c(r.gyr, dtype=np.float64) for r in recs])
        self.accs = List([c(r.acc, dtype=np.float64) for r in recs])
        self.mags = List([c(r.mag, dtype=np.float64) if r.mag is not None else np.empty((0, 3)) for r in recs])
        self.trues = List([c(r.quat, dtype=np.float64) for r in recs])
        self.masks = List([c(obj._mask(r), dtype=np.bool_) for r in recs])
        self.n = np.array([r.n for r in recs], dtype=np.int64)
        self.q0: dict[tuple, np.ndarray] = {}
        self.gravity = [gravity_in_units(r) for r in recs]  # g_ref of kernel_setup
        frame = obj._cls.working_frame
        self.rots = np.zeros((len(recs), 5))
        for i, r in enumerate(recs):
            self.rots[i, :4] = frame_rotation(frame, r.frame)
            self.rots[i, 4] = 0.0 if frame.upper() == r.frame.upper() else 1.0
        self._angles: List | None = None
        self._tilt: tuple | None = None

    def angles(self) -> List:
        """The true angles ``mse_1d`` compares with, per recording (``FilterObjective._mse_1d``'s choice)."""
        if self._angles is None:
            out = []
            for rec in self.recs:
                true = rec.extra.get("angle")
                if true is None:
                    true = euler_zyx(rec.quat)[:, 1]
                out.append(np.ascontiguousarray(np.asarray(true, dtype=float).ravel()))
            self._angles = List(out)
        return self._angles

    def tilt_inputs(self) -> tuple:
        """The 1-D filters' inputs per recording (gyro y, acc x, acc z, as ``kf1d._inputs``) and each frame's
        up sign, made once like the other arrays (not per generation)."""
        if self._tilt is None:
            c = np.ascontiguousarray
            cols = tuple(List([c(getattr(r, a)[:, k], dtype=np.float64) for r in self.recs])
                         for a, k in (("gyr", 1), ("acc", 0), ("acc", 2)))
            self._tilt = (*cols, np.array([_up_sign(r.frame) for r in self.recs]))
        return self._tilt

    def initial(self, obj: Any, flt: Any, i: int) -> np.ndarray:
        """The start quaternion of ``flt`` on recording ``i`` (``AttitudeFilter._run_detailed``'s)."""
        rec = self.recs[i]
        if flt.needs_mag and flt.values.get("use_mag", True) and rec.mag is None:
            raise ValueError(f"{flt.name}: recording {rec.name!r} has no magnetometer; set use_mag: false")
        use_mag = bool(flt.values.get("use_mag", True)) and rec.mag is not None
        init = flt.values.get("init", "auto")
        how = obj.q0 if init == "auto" else init
        key = (i, repr(how), use_mag)
        if key not in self.q0:
            self.q0[key] = initial_quaternion(rec, flt.working_frame, how, use_mag=use_mag)
        return self.q0[key]


def _data(obj: Any) -> _Data:
    """The train recordings as the kernels read them, kept with the objective's prepared train split."""
    prepared = obj.prepare("train")
    if prepared.batch is None:
        prepared.batch = _Data(obj)
    return prepared.batch


def _sums(out: np.ndarray) -> ErrorSums:
    """:func:`objectives.attitude.fused_errors.error_sums`'s result from the kernel's sums."""
    n = int(out[9])
    if n == 0:
        nan = np.full(3, np.nan)
        return ErrorSums(0, 0, nan, nan.copy(), nan.copy())
    return ErrorSums(n, int(out[10]), out[0:3] / n, out[3:6] / n, out[6:9] / n)


def _score(obj: Any, recs: list, sums: list[ErrorSums], mse_1d: list | None, segments: list) -> Score:
    """:meth:`FilterObjective.score` on the train data from the error sums (every recording has truth);
    ``mse_1d``: the 1-D filters' ``mse_1d`` per recording (computed in the kernel); ``segments``: each
    recording's growth segments (mean squares, counts) for the divergence check."""
    per: dict[str, dict[str, float]] = {}
    failed = ""
    for i, (rec, es, (ms, count)) in enumerate(zip(recs, sums, segments)):
        failed = recording_failure(rec.name, es, failed,
                                   partial(growth_verdict, np.degrees(np.sqrt(ms)), count.astype(np.int64)))
        per[rec.name] = dict(es.as_dict())
        if obj.metric == "mse_1d":
            per[rec.name]["mse_1d"] = float(mse_1d[i])
    fitness = obj._combine(sums, per, [r.name for r in recs], "train")
    return Score(float(fitness), per, failed)


def _prepare(obj: Any, data: _Data, kernel: _Kernel, params_list: Sequence[Mapping[str, Any]], results: list):
    """Per pair: the filter's :meth:`~objectives.attitude.filters.base.AttitudeFilter.kernel_setup` (coefficients
    and initial state, as its serial run builds them), magnetometer use (and fuzzy tables); failures into
    ``results``."""
    rows: list[tuple[int, int, np.ndarray, np.ndarray, int, Any, tuple]] = []
    for ci, params in enumerate(params_list):
        try:
            flt = obj.make_filter(params)
            pairs = []
            for ri, rec in enumerate(data.recs):
                q0 = data.initial(obj, flt, ri)
                use_mag = bool(flt.values.get("use_mag", True)) and rec.mag is not None
                setup = flt.kernel_setup(rec.dt, use_mag, q0, rec.frame, data.gravity[ri])
                fz = kernel.tables(flt) if kernel.tables is not None else None
                pairs.append((ci, ri, setup.coef, setup.state, int(use_mag), fz, setup.extra))
            rows += pairs
        except Exception as exc:  # this candidate fails as it would serially; the others go on
            results[ci] = exc
    return rows


def _disturbances(obj: Any, data: _Data, flt: Any) -> tuple[List, List, List]:
    """The FAEKF's fuzzy inputs per recording, the prepared ones its serial path uses."""
    outs = ([], [], [])
    prepared = obj.prepare("train")
    for i, rec in enumerate(data.recs):
        d = prepared.disturbances(flt, i)
        d = flt._as_disturbances(rec, d.vib_freq_hz, d.ext_acc_g, d.mag_pert_nu)
        for lst, a in zip(outs, (d.vib_freq_hz, d.ext_acc_g, d.mag_pert_nu)):
            lst.append(a)
    return List(outs[0]), List(outs[1]), List(outs[2])


def evaluate_batch(obj: Any, params_list: Sequence[Mapping[str, Any]], n_threads: int) -> list[Any] | None:
    """Evaluations of ``params_list`` equal to ``[obj(p) for p in params_list]`` (None: not batchable).

    An item is the :class:`~tuner.objective.Evaluation` or the exception the serial call raises.
    """
    if not batchable(obj):
        return None
    kernel = _kernel(obj)
    data = _data(obj)
    results: list[Any] = [None] * len(params_list)
    rows = _prepare(obj, data, kernel, params_list, results)
    n_lanes = use_threads(n_threads)
    P = len(rows)
    pair_rec = np.array([r[1] for r in rows], dtype=np.int64)
    pair_mag = np.array([r[4] for r in rows], dtype=np.int64)
    coefs = np.zeros((P, max([len(r[2]) for r in rows] or [kernel.coef_len])))
    states = np.zeros((P, max([len(r[3]) for r in rows] or [kernel.state_len])))
    for k, r in enumerate(rows):
        coefs[k, :len(r[2])] = r[2]
        states[k, :len(r[3])] = r[3]
    order = deal(data.n[pair_rec] if P else np.zeros(0))  # longest first, claimed by free lanes
    n_max = int(data.n.max()) if len(data.n) else 0
    sums = np.zeros((P, _N_SUMS))
    mse = kernel.run(obj, data, params_list, rows, (pair_rec, pair_mag, coefs, states), (order, counter()),
                     (n_lanes, n_max), sums)
    return _results(obj, data, params_list, rows, sums, mse, results)


def _run_bias(family: int, obj: Any, data: _Data, params_list, rows, pairs, lanes_, shape, sums) -> None:
    """Madgwick (``family`` 0) or Mahony (1) on every pair (:func:`_bias_batch`)."""
    recs = (data.gyrs, data.accs, data.mags, data.trues, data.masks, data.rots)
    _bias_batch(family, recs, pairs, lanes_, (np.empty((*shape, 4)), np.empty((*shape, 4))), sums)


def _run_ekf(fuzzy: bool, obj: Any, data: _Data, params_list, rows, pairs, lanes_, shape, sums) -> None:
    """The EKF or (``fuzzy``) the FAEKF on every pair (:func:`_ekf_batch`), with each pair's fuzzy tables."""
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
    recs = (data.gyrs, data.accs, data.mags, data.trues, data.masks, data.rots)
    bufs = (np.empty((n_lanes, n_max, 4)), np.empty((n_lanes, n_max, 3)), np.empty((n_lanes, n_max, 4)),
            np.empty((n_lanes, n_max if fuzzy else 0)))
    _ekf_batch(1 if fuzzy else 0, recs, pairs, lanes_, (vibs, exts, mps, mf_kind, mf_params, rules, cons), bufs,
               sums)


def _run_kf1d(obj: Any, data: _Data, params_list, rows, pairs, lanes_, shape, sums) -> np.ndarray:
    """The thesis 1-D tilt KF on every pair (:func:`_kf1d_batch`); returns each pair's ``mse_1d``."""
    n_lanes, n_max = shape
    pair_rec, _, coefs, states = pairs
    mse = np.full(len(rows), np.nan)
    gy, ax, az, up = data.tilt_inputs()
    _kf1d_batch((gy, ax, az, data.trues, data.masks, up, data.angles()), (pair_rec, coefs, states), lanes_,
                (np.empty((n_lanes, n_max)), np.empty((n_lanes, n_max, 4)), np.empty((n_lanes, n_max)),
                 np.empty((n_lanes, n_max))), sums, mse)
    return mse


def _run_ukf(obj: Any, data: _Data, params_list, rows, pairs, lanes_, shape, sums) -> None:
    """The QUKF / QRAUKF on every pair (:func:`_ukf_batch`), each from its setup's integer state."""
    n_lanes, n_max = shape
    istates = np.array([r[6][0] for r in rows], dtype=np.int64).reshape(len(rows), 4)
    recs = (data.gyrs, data.accs, data.mags, data.trues, data.masks, data.rots)
    flags = np.zeros((n_lanes, n_max), dtype=np.bool_)
    _ukf_batch(recs, pairs, istates, lanes_, (np.empty((n_lanes, n_max, 4)), np.empty((n_lanes, n_max, 4)),
                                              np.empty((n_lanes, n_max, 3)), np.empty((n_lanes, n_max, 3)), flags,
                                              flags.copy()), sums)


def _fuzzy_tables(flt: Any) -> tuple:
    """The FAEKF's per-candidate tables: set parameters (3, 3, 4), rule consequents (27,), values."""
    return flt.membership_table(), faekf_rules(flt.singletons())[1], flt.values


@dataclass(frozen=True)
class _Kernel:
    """A population kernel a filter class can declare (``batch_kernel``).

    run : ``run(obj, data, params_list, rows, pairs, lanes_, (n_lanes, n_max), sums)`` runs every pair into
        ``sums`` and returns the pairs' ``mse_1d`` (None when the kernel keeps no angle).
    coef_len, state_len : widths of the coefficient and state arrays when there is no pair.
    mse_1d : the kernel computes ``mse_1d`` (the 1-D filters' angle is kept per pair).
    robust : the kernel runs the filter's robust blocks (else a configuration with one on is serial).
    tables : per candidate, what the kernel needs besides coefficients and state (None: nothing).
    """

    run: Callable[..., np.ndarray | None]
    coef_len: int
    state_len: int
    mse_1d: bool = False
    robust: bool = True
    tables: Callable[[Any], Any] | None = None


#: the population kernels by the name a filter class declares in ``batch_kernel``
_KERNELS: dict[str, _Kernel] = {
    "madgwick": _Kernel(partial(_run_bias, 0), 5, 7),
    "mahony": _Kernel(partial(_run_bias, 1), 5, 7),
    "ekf": _Kernel(partial(_run_ekf, False), 12, 7, robust=False),
    "faekf": _Kernel(partial(_run_ekf, True), 12, 7, robust=False, tables=_fuzzy_tables),
    "kf1d": _Kernel(_run_kf1d, 4, 5, mse_1d=True),
    "ukf": _Kernel(_run_ukf, 8, 52, robust=False),
}


def _results(obj: Any, data: _Data, params_list: Sequence[Mapping[str, Any]], rows: list, sums: np.ndarray,
             mse: np.ndarray | None, results: list) -> list[Any]:
    """Each candidate's evaluation from its pairs' sums (and ``mse_1d`` values), by the objective's own code."""
    per_cand: dict[int, list[ErrorSums]] = {}
    segments: dict[int, list[tuple[np.ndarray, np.ndarray]]] = {}
    mses: dict[int, list[float]] = {}
    for k, r in enumerate(rows):
        per_cand.setdefault(r[0], []).append(_sums(sums[k]))
        segments.setdefault(r[0], []).append((sums[k, _N_ERR:_N_ERR + N_SEGMENTS], sums[k, _N_ERR + N_SEGMENTS:]))
        if mse is not None:
            mses.setdefault(r[0], []).append(mse[k])
    for ci, es in per_cand.items():
        try:
            results[ci] = obj._evaluation(params_list[ci], _score(obj, data.recs, es, mses.get(ci), segments[ci]))
        except Exception as exc:
            results[ci] = exc
    return results
