"""Time stamps of a logged recording: stamps that do not increase, sample-and-hold, resampling, truth sanity.

A logger's rows are not an IMU's samples. This module turns the rows of a CSV file
(:mod:`objectives.attitude.data.csv`) into what filters need, all of it vectorised:

Stamps that do not increase (:func:`increasing`)
    A row whose stamp is not after the largest stamp before it (a duplicate, or a stamp that went back) is
    dropped; the first row of a stamp is kept. More than ``max_dropped_share`` of the rows dropped is an error:
    such a time column is not a clock.
Sample-and-hold (:func:`held_rows`, :func:`hold_share`, :func:`imu_clock`)
    A row whose gyroscope, accelerometer and magnetometer values all equal the previous row's repeats the IMU's
    previous sample (the log runs faster than the IMU). When more than :data:`HOLD_SHARE` of the rows in motion
    (gyroscope norm above :data:`HOLD_MOTION_RAD_S`: a moving sensor never repeats a reading, while noise-free
    data at rest do) repeat, the IMU's own rate is its distinct samples per second. A new sample first appears
    in the first row logged after it was taken, on average half a log period later (the log's phase against
    the IMU's is uniform), so with ``resample_hz`` each distinct sample is placed at the stamp of that row less
    half the median log period.
Resampling (``resample_hz``, :func:`resample_imu`)
    IMU channels are interpolated linearly onto a uniform grid from the first to the last IMU sample. The
    gyroscope follows the project's convention (:mod:`objectives.attitude.data.imu_model`): sample ``k`` is the
    rate over ``[t_k, t_k + dt]``, so a sample is placed at the middle of its own period and read at the middle
    of the grid's. The truth is interpolated by slerp (:func:`slerp`) between its rows; where two neighbouring
    truth rows are further apart than ``max_truth_gap_s`` (or one is NaN) the truth is NaN.
Truth sanity (:func:`truth_sanity`)
    A truth row whose norm is outside ``1 +- quat_norm_tol`` is NaN. A step between two truth rows faster than
    ``truth_rate_factor`` times the largest gyroscope norm within :data:`RATE_WINDOW_S` around it, plus
    :data:`RATE_FLOOR_RAD_S`, is a jump of the reference (a marker swap, a flipped solution): a row between two
    such steps (a spike) is NaN, and both rows of a lone such step (the start or end of a stretch).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np

__all__ = ["ReadInfo", "HOLD_SHARE", "HOLD_MOTION_RAD_S", "RATE_WINDOW_S", "RATE_FLOOR_RAD_S", "increasing",
           "held_rows", "hold_share", "imu_clock", "median_step", "resample_imu", "slerp", "step_rates",
           "truth_sanity", "body_rates"]

#: share of the rows in motion repeating the previous IMU sample above which the log holds samples
HOLD_SHARE = 0.05
#: gyroscope norm (rad/s) above which a row is in motion for the sample-and-hold share
HOLD_MOTION_RAD_S = 0.1
#: half-width (s) of the window in which the gyroscope's largest norm bounds the truth's rate
RATE_WINDOW_S = 0.25
#: rad/s (~57 deg/s) added to that bound: noise and small lags never flag a step
RATE_FLOOR_RAD_S = 1.0


@dataclass(frozen=True)
class ReadInfo:
    """What reading a logged file found (``Recording.meta["read"]``).

    Attributes
    ----------
    rows : int
        Data rows in the file.
    dropped_stamps : int
        Rows dropped because their stamp was not after the largest one before them.
    held_rows : int
        Kept rows repeating the previous IMU sample exactly (sample-and-hold).
    log_rate_hz : float
        Rate of the kept rows (1 / median step), Hz; NaN without a time column.
    imu_rate_hz : float
        The IMU's own rate (distinct samples per second), Hz; equal to ``log_rate_hz`` without sample-and-hold.
    resampled_hz : float or None
        ``resample_hz`` when the IMU was resampled.
    largest_imu_gap_s : float
        The largest step between two IMU samples, s.
    truth_nan_norm, truth_nan_rate : int
        Truth rows set to NaN: norm far from 1; around a step far faster than the gyroscope.
    truth_nan_gap : int
        Output samples whose truth falls between two rows further apart than ``max_truth_gap_s``.
    start_s : float
        Time of the recording's first sample on the file's clock, s (its sample ``k`` is at
        ``start_s + k dt``).
    """

    rows: int
    dropped_stamps: int = 0
    held_rows: int = 0
    log_rate_hz: float = math.nan
    imu_rate_hz: float = math.nan
    resampled_hz: float | None = None
    largest_imu_gap_s: float = math.nan
    truth_nan_norm: int = 0
    truth_nan_rate: int = 0
    truth_nan_gap: int = 0
    start_s: float = 0.0

    def as_dict(self) -> dict:
        return asdict(self)


def increasing(t: np.ndarray) -> np.ndarray:
    """Mask (N,) of the rows to keep: each stamp after the largest stamp before it (the first always kept)."""
    keep = np.ones(t.shape[0], dtype=bool)
    if t.shape[0] > 1:
        keep[1:] = t[1:] > np.maximum.accumulate(t)[:-1]
    return keep


def held_rows(imu: np.ndarray) -> np.ndarray:
    """Mask (N,) of rows equal in every column of ``imu`` (N, k) to the row before (row 0 never)."""
    held = np.zeros(imu.shape[0], dtype=bool)
    held[1:] = np.all(imu[1:] == imu[:-1], axis=1)
    return held


def hold_share(held: np.ndarray, gyr_norm: np.ndarray) -> float:
    """The share of the rows in motion (``gyr_norm`` above :data:`HOLD_MOTION_RAD_S`) that are ``held``; 0 when
    no row is in motion."""
    moving = gyr_norm > HOLD_MOTION_RAD_S
    return float(held[moving].mean()) if moving.any() else 0.0


def median_step(t: np.ndarray) -> float:
    """The median positive step of the stamps ``t``, s (NaN when there is none)."""
    d = np.diff(t)
    d = d[d > 0]
    return float(np.median(d)) if d.size else math.nan


def imu_clock(t: np.ndarray, held: np.ndarray, hold: bool) -> tuple[np.ndarray, float]:
    """Times (s) of the IMU's samples and the IMU's period (s).

    Without sample-and-hold (``hold`` False) every row is a sample at its stamp. Otherwise the rows not
    ``held``, each at its stamp less half the median log period (module docstring), and the period is the mean
    step between them, steps longer than three times their median left out (a gap in the log loses samples).
    """
    if not hold or (~held).sum() < 2:
        return t, median_step(t)
    ts = t[~held] - 0.5 * median_step(t)
    steps = np.diff(ts)
    steps = steps[steps <= 3.0 * np.median(steps)]
    return ts, float(steps.mean())


def resample_imu(t_imu: np.ndarray, period: float, columns: dict, rate_hz: float) -> tuple[np.ndarray, dict]:
    """The uniform grid (M,) at ``rate_hz`` over the IMU samples and each of ``columns`` interpolated onto it.

    ``columns``: name -> (N,) or (N, k) values at ``t_imu``; ``gyr`` is read at the grid's interval middles
    from samples placed at their own interval middles (``period``), ``motion`` takes the last sample at or
    before each grid time, the others are interpolated at the grid times.
    """
    step = 1.0 / rate_hz
    m = int(math.floor((t_imu[-1] - t_imu[0]) / step + 1e-9)) + 1
    grid = t_imu[0] + step * np.arange(m)
    out = {}
    for name, v in columns.items():
        if v is None:
            out[name] = None
            continue
        if name == "motion":
            i = np.clip(np.searchsorted(t_imu, grid, side="right") - 1, 0, t_imu.shape[0] - 1)
            out[name] = v[i]
            continue
        src, query = (t_imu + 0.5 * period, grid + 0.5 * step) if name == "gyr" else (t_imu, grid)
        a = v.reshape(v.shape[0], -1)
        res = np.column_stack([np.interp(query, src, a[:, j]) for j in range(a.shape[1])])
        out[name] = res if v.ndim == 2 else res[:, 0]
    return grid, out


def slerp(t: np.ndarray, q: np.ndarray, tq: np.ndarray, max_gap_s: float = math.inf) -> np.ndarray:
    """Quaternions ``q`` (N, 4) at stamps ``t`` (N,, increasing) interpolated by slerp at ``tq`` (M,).

    NaN rows: ``tq`` outside ``[t[0], t[-1]]``, between two rows further apart than ``max_gap_s`` or with a
    non-finite neighbour. The result is unit-norm; the shorter arc is taken (``q`` and ``-q`` are one rotation).
    """
    n = t.shape[0]
    out = np.full((tq.shape[0], 4), np.nan)
    if n < 2:
        return out
    i = np.searchsorted(t, tq, side="right") - 1
    i = np.where(tq == t[-1], n - 2, i)
    ok = (i >= 0) & (i <= n - 2)
    i = np.clip(i, 0, n - 2)
    t0, t1 = t[i], t[i + 1]
    q0, q1 = q[i], q[i + 1]
    ok &= (t1 - t0) <= max_gap_s * (1 + 1e-9)
    ok &= np.isfinite(q0).all(axis=1) & np.isfinite(q1).all(axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        u = ((tq - t0) / (t1 - t0))[:, None]
        q0 = q0 / np.linalg.norm(q0, axis=1, keepdims=True)
        q1 = q1 / np.linalg.norm(q1, axis=1, keepdims=True)
        d = np.sum(q0 * q1, axis=1, keepdims=True)
        q1 = np.where(d < 0, -q1, q1)
        d = np.clip(np.abs(d), 0.0, 1.0)
        th = np.arccos(d)
        s = np.sin(th)
        small = s < 1e-9
        a = np.where(small, 1.0 - u, np.sin((1.0 - u) * th) / np.where(small, 1.0, s))
        b = np.where(small, u, np.sin(u * th) / np.where(small, 1.0, s))
        r = a * q0 + b * q1
        r /= np.linalg.norm(r, axis=1, keepdims=True)
    out[ok] = r[ok]
    return out


def step_rates(t: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Rotation rate (rad/s) of each step between consecutive rows of ``q`` (N, 4): (N-1,), NaN where a row is
    not finite; sign-free (``q`` and ``-q`` are one rotation), norms need not be 1."""
    with np.errstate(invalid="ignore", divide="ignore"):
        nq = np.linalg.norm(q, axis=1)
        c = np.abs(np.sum(q[1:] * q[:-1], axis=1)) / (nq[1:] * nq[:-1])
        return 2.0 * np.arccos(np.clip(c, 0.0, 1.0)) / np.diff(t)


def body_rates(t: np.ndarray, q: np.ndarray, max_gap_s: float = math.inf) -> tuple[np.ndarray, np.ndarray]:
    """Body-frame angular rate of each step of ``q`` (N, 4) at stamps ``t``: ``2 log(conj(q_k) q_k+1) / dt``
    (the gyroscope convention of :mod:`objectives.attitude.data.imu_model`), placed at the step's middle.

    Returns
    -------
    (mid, w)
        ``mid`` (N-1,) s; ``w`` (N-1, 3) rad/s, NaN where a row is not finite or the step is longer than
        ``max_gap_s``.
    """
    from objectives.attitude.quaternion import qconj_batch, qlog_batch, qmul_batch

    dt = np.diff(t)
    bad = ~(np.isfinite(q[:-1]).all(axis=1) & np.isfinite(q[1:]).all(axis=1)) | (dt > max_gap_s * (1 + 1e-9))
    q0 = np.where(bad[:, None], [1.0, 0.0, 0.0, 0.0], q[:-1])
    q1 = np.where(bad[:, None], [1.0, 0.0, 0.0, 0.0], q[1:])
    q0 = q0 / np.linalg.norm(q0, axis=1, keepdims=True)
    q1 = q1 / np.linalg.norm(q1, axis=1, keepdims=True)
    dq = qmul_batch(qconj_batch(q0), q1)
    dq = np.where(dq[:, :1] < 0, -dq, dq)  # the shorter arc
    w = qlog_batch(np.ascontiguousarray(dq)) / dt[:, None]
    w[bad] = np.nan
    return 0.5 * (t[:-1] + t[1:]), w


def truth_sanity(t: np.ndarray, q: np.ndarray, gyr_norm: np.ndarray, norm_tol: float,
                 rate_factor: float) -> tuple[np.ndarray, int, int]:
    """``q`` (N, 4) with implausible rows set to NaN (module docstring) and the counts (norm, rate).

    ``gyr_norm`` (N,) is the gyroscope's norm at the same rows, rad/s.
    """
    from scipy.ndimage import maximum_filter1d

    q = np.array(q, dtype=float)
    finite = np.isfinite(q).all(axis=1)
    norm = np.linalg.norm(np.where(finite[:, None], q, 0.0), axis=1)
    bad_norm = finite & (np.abs(norm - 1.0) > norm_tol)
    q[bad_norm] = np.nan
    n = q.shape[0]
    if n < 2:
        return q, int(bad_norm.sum()), 0
    step = median_step(t)
    half = int(math.ceil(RATE_WINDOW_S / step)) if np.isfinite(step) else 1
    gmax = maximum_filter1d(np.asarray(gyr_norm, float), size=2 * half + 1, mode="nearest")
    rates = step_rates(t, q)
    with np.errstate(invalid="ignore"):
        fast = rates > rate_factor * np.maximum(gmax[:-1], gmax[1:]) + RATE_FLOOR_RAD_S
    before = np.concatenate([[False], fast])
    after = np.concatenate([fast, [False]])
    spike = before & after
    lone = fast & ~spike[:-1] & ~spike[1:]
    bad_rate = spike | np.concatenate([[False], lone]) | np.concatenate([lone, [False]])
    bad_rate &= ~bad_norm & np.isfinite(q).all(axis=1)
    q[bad_rate] = np.nan
    return q, int(bad_norm.sum()), int(bad_rate.sum())
