"""Population evaluation of the filter objective in one numba kernel (``backend: threads``): the lane machinery.

:meth:`FilterObjective.evaluate_batch` comes here. For every (candidate, recording) pair the Python
side builds what the serial path would hand the filter kernel (the validated filter, and its
:meth:`~objectives.attitude.filters.base.AttitudeFilter.kernel_setup`: coefficient array, start state and
further start arrays, plus per candidate what the unit's ``tables`` give); the filter's population kernel,
one ``@njit(parallel=True)`` kernel, then runs for every pair the filter's own per-recording kernel, the frame
conversion of :func:`objectives.attitude.quaternion.to_frame` and the one-pass error sums of
:mod:`objectives.attitude.fused_errors` (:func:`pair_sums`), threads sharing the recordings (see
:mod:`objectives.batch_threads` for lanes, dynamic claiming and buffers). The sums are combined per candidate by
the objective's own code (``_combine`` and ``_evaluation``), so each result equals what ``__call__``
returns for the same parameters, bit for bit (tests/attitude/test_filter_batch.py).

The population kernel belongs to the filter's unit (``population.py`` beside its kernel): a class declares it
as its own ``population`` (a :class:`Population`; a subclass, which may change ``_run``, declares its own),
and this module never names a filter. Batched where a unit has one (``docs/architecture.md`` lists them), on
recordings that all have truth, without ``heading_offset: remove`` (its truth depends on each candidate's
output); with ``mse_1d`` only where the kernel keeps the angle. For any other
configuration :func:`evaluate_batch` returns None and the engine evaluates serially.

Importing this module (which every unit's ``population.py`` does, so every filter class) leaves ``numba.typed``
unimported until a batch runs: its templates make numba type every later kernel 2-5 % slower (measured on a
filter kernel's compile).

The population kernels call kernels of other modules and are cached on disk under rule 3 of
:mod:`objectives.jit` (each entry keyed on the whole package's sources): they compile once per machine,
not in every process on its first batch; their callees are compiled into them (rule 2).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from functools import partial
from typing import Any

import numpy as np
from numba import njit

from objectives.attitude.divergence import N_SEGMENTS, _segment_ms_inner, growth_verdict, recording_failure
from objectives.attitude.filters.base import gravity_in_units, initial_quaternion, own
from objectives.attitude.fused_errors import ErrorSums, _error_sums_inner
from objectives.attitude.quaternion import euler_zyx
from objectives.attitude.quaternion.algebra import _qmul_kernel_inner
from objectives.attitude.quaternion.conversions import frame_rotation
from objectives.batch_threads import _pairwise_sum, claim, counter, deal, use_threads
from tuner.objective import Score

__all__ = ["evaluate_batch", "batchable", "Population", "BatchData", "N_SUMS", "claim_pair", "pair_sums",
           "lane_sums", "mse_1d_kernel"]

#: per pair: the 11 error sums of fused_errors, then the N_SEGMENTS mean squares and counts of divergence
_N_ERR = 11
#: the width of a pair's row of ``sums`` (what a population kernel writes per pair)
N_SUMS = _N_ERR + 2 * N_SEGMENTS


@njit(cache=False)
def pair_sums(q, c, rots, r, true, mask, acc, out):
    """Error sums and growth segments (``out``, :data:`N_SUMS`) of the estimate ``q`` of recording ``r``
    (converted into ``c`` to its frame if needed), accumulated in the lane's own ``acc`` (see
    :func:`lane_sums`)."""
    if rots[r, 4] != 0.0:
        _qmul_kernel_inner(rots[r:r + 1, :4], q, c)
        q = c
    lane_sums(q, true, mask, acc, out)


@njit(cache=False)
def lane_sums(q, true, mask, acc, out):
    """The error sums and growth segments of ``q`` into ``out``, accumulated per sample in ``acc`` (the
    lane's (:data:`N_SUMS`,) array) and copied once: rows of ``sums`` that two lanes fill at the same
    time can share a cache line, which per-sample updates would pass between the cores all the time."""
    _error_sums_inner(q, true, mask, acc[:_N_ERR])
    _segment_ms_inner(q, true, mask, acc[_N_ERR:])
    out[:] = acc


@njit(cache=False, inline="always")
def claim_pair(lanes_, data, pairs, qbuf, lane, no_mag):
    """The next pair the lane claims (:mod:`objectives.batch_threads`): pair, recording, length, the lane's
    output view and the magnetometer it uses; pair -1 once every pair is claimed.

    data : :attr:`BatchData.arrays`; pairs : ``(rec, use_mag, coefs, states)`` (:func:`evaluate_batch`).
    """
    order, count = lanes_
    j = claim(count)
    if j >= order.shape[0]:
        return -1, 0, 0, qbuf[lane, :0], no_mag
    p = order[j]
    r = pairs[0][p]
    n = data[0][r].shape[0]
    mag = data[2][r] if pairs[1][p] != 0 else no_mag
    return p, r, n, qbuf[lane, :n], mag


@njit(cache=False)
def _wrap_angle(a):
    """:func:`objectives.attitude.metrics.wrap_angle` of one value, bit for bit (``np.mod``'s rules)."""
    two_pi = 2.0 * np.pi
    out = (a + np.pi) % two_pi - np.pi  # Python's float % has np.mod's rules (fmod, then the divisor's sign)
    return out - two_pi if out >= np.pi else out


@njit(cache=False)
def mse_1d_kernel(est, true, mask, e):
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



@dataclass(frozen=True)
class Population:
    """A filter unit's population kernel, as its class declares it (``population``).

    run : ``run(obj, data, params_list, rows, pairs, lanes_, (n_lanes, n_max), sums)`` runs every pair into
        ``sums`` (P, :data:`N_SUMS`) and returns the pairs' ``mse_1d`` (None when the kernel keeps no angle).
        ``data`` is the :class:`BatchData`, ``rows`` the pairs (:func:`evaluate_batch`), ``pairs`` the arrays
        ``(rec, use_mag, coefs, states)`` and ``lanes_`` the ``(order, count)`` of the lanes' claiming.
    coef_len, state_len : widths of the coefficient and state arrays when there is no pair (the kernel's layouts).
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


def _population(obj: Any) -> Population | None:
    """The population kernel the objective's filter class declares (its own ``population``)."""
    return own(obj._cls, "population")


def batchable(obj: Any) -> bool:
    """True when :func:`evaluate_batch` can evaluate this objective's configuration (module docstring)."""
    kernel = _population(obj)
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


class BatchData:
    """The recordings as the kernels read them (built once per objective, shared by every batch).

    ``arrays`` is ``(gyrs, accs, mags, trues, masks, rots)``: typed lists, one array per recording
    (``mags[r]`` (0, 3) without one), and ``rots`` (R, 5): the rotation quaternion from the filter's working
    frame to the recording's and 1.0 when a conversion is needed. A unit keeps arrays of its own (computed once,
    like these) with :meth:`memo`.
    """

    def __init__(self, obj: Any):
        from numba.typed import List  # here, not at import: its templates slow the typing of every later kernel

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
        self.arrays = (self.gyrs, self.accs, self.mags, self.trues, self.masks, self.rots)
        self._memo: dict[str, Any] = {}

    def memo(self, key: str, make: Callable[[], Any]) -> Any:
        """``make()``, computed on the first call with ``key`` and kept with the data (a unit's own arrays)."""
        if key not in self._memo:
            self._memo[key] = make()
        return self._memo[key]

    def angles(self) -> Any:
        """The true angles ``mse_1d`` compares with, per recording (``FilterObjective._mse_1d``'s choice): a typed
        list."""
        from numba.typed import List

        def make() -> List:
            out = []
            for rec in self.recs:
                true = rec.extra.get("angle")
                if true is None:
                    true = euler_zyx(rec.quat)[:, 1]
                out.append(np.ascontiguousarray(np.asarray(true, dtype=float).ravel()))
            return List(out)

        return self.memo("mse_1d angles", make)

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


def _data(obj: Any) -> BatchData:
    """The train recordings as the kernels read them, kept with the objective's prepared train split."""
    prepared = obj.prepare("train")
    if prepared.batch is None:
        prepared.batch = BatchData(obj)
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


def _prepare(obj: Any, data: BatchData, kernel: Population, params_list: Sequence[Mapping[str, Any]],
             results: list):
    """Per pair: the filter's :meth:`~objectives.attitude.filters.base.AttitudeFilter.kernel_setup` (coefficients
    and initial state, as its serial run builds them), magnetometer use (and the unit's tables); failures into
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


def evaluate_batch(obj: Any, params_list: Sequence[Mapping[str, Any]], n_threads: int) -> list[Any] | None:
    """Evaluations of ``params_list`` equal to ``[obj(p) for p in params_list]`` (None: not batchable).

    An item is the :class:`~tuner.objective.Evaluation` or the exception the serial call raises.
    """
    if not batchable(obj):
        return None
    kernel = _population(obj)
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
    sums = np.zeros((P, N_SUMS))
    mse = kernel.run(obj, data, params_list, rows, (pair_rec, pair_mag, coefs, states), (order, counter()),
                     (n_lanes, n_max), sums)
    return _results(obj, data, params_list, rows, sums, mse, results)


def _results(obj: Any, data: BatchData, params_list: Sequence[Mapping[str, Any]], rows: list, sums: np.ndarray,
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


#: the name ``tests/attitude/test_batch_mse_1d.py`` checks against ``metrics.mse_1d``
_mse_1d_kernel = mse_1d_kernel
