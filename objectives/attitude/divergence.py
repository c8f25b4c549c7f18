"""Detection of a clearly wrong filter output: an attitude error that grows without bound.

A filter whose estimate is non-finite has diverged, and :class:`~objectives.attitude.objective.FilterObjective`
records it as a failed evaluation. A filter can also stay finite while its error runs away (a gyro
bias integrated with no working correction, a gain at its stability bound): its RMSE is then a
finite number that a mean over recordings dilutes and an optimiser may even accept. Such an output
is a recorded failure too, by this criterion:

The samples scored (motion mask, finite truth) are split, in time order, into ``N_SEGMENTS = 4``
consecutive segments of equal count. With ``e_s`` the RMS total attitude error (BROAD's total
error, the angle of ``q_est * conj(q_true)``) of segment ``s``, the error *grows without bound* when

- it never decreases from one segment to the next (``e_1 <= e_2 <= e_3 <= e_4``),
- the last segment's error is at least ``GROWTH_RATIO = 3`` times the first's, and
- the last segment's error exceeds ``GROWTH_LIMIT_DEG = 60`` deg (a third of the largest possible
  error: no tuning choice of a working filter ends a recording there).

A filter that is offset or noisy but bounded is not flagged (its segments do not grow monotonically
by a factor 3, or stay below 60 deg); one that drifts steadily away from the truth is. Recordings
with fewer than ``4 * MIN_SEGMENT`` scored samples are not judged.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np
from numba import njit

from objectives.jit import uncached

__all__ = ["N_SEGMENTS", "GROWTH_RATIO", "GROWTH_LIMIT_DEG", "MIN_SEGMENT", "segment_rms_deg", "unbounded_growth",
           "growth_verdict", "recording_failure"]

N_SEGMENTS = 4
GROWTH_RATIO = 3.0
GROWTH_LIMIT_DEG = 60.0
MIN_SEGMENT = 10


@njit(cache=True)
def _segment_ms(q_est, q_true, mask, out):
    """out[s] = mean squared total error (rad^2) of segment s of the scored samples; out[4 + s] = count.

    Scored: mask true and finite truth; a non-finite estimate counts as a pi error (as
    :mod:`objectives.attitude.fused_errors`).
    """
    ns = out.shape[0] // 2
    for k in range(out.shape[0]):
        out[k] = 0.0
    n = 0
    for i in range(q_true.shape[0]):
        if mask[i] and math.isfinite(q_true[i, 0] + q_true[i, 1] + q_true[i, 2] + q_true[i, 3]):
            n += 1
    if n == 0:
        return
    j = 0
    for i in range(q_true.shape[0]):
        tw, tx, ty, tz = q_true[i, 0], q_true[i, 1], q_true[i, 2], q_true[i, 3]
        if not (mask[i] and math.isfinite(tw + tx + ty + tz)):
            continue
        s = (j * ns) // n
        j += 1
        w, x, y, z = q_est[i, 0], q_est[i, 1], q_est[i, 2], q_est[i, 3]
        ne = math.sqrt(w * w + x * x + y * y + z * z)
        nt = math.sqrt(tw * tw + tx * tx + ty * ty + tz * tz)
        if not (math.isfinite(ne) and ne > 0.0 and nt > 0.0):
            ang = math.pi
        else:
            dot = abs(w * tw + x * tx + y * ty + z * tz) / (ne * nt)
            ang = 2.0 * math.acos(min(1.0, dot))
        out[s] += ang * ang
        out[ns + s] += 1.0
    for s in range(ns):
        if out[ns + s] > 0:
            out[s] /= out[ns + s]


#: the uncached twin other kernels call (objectives.jit)
_segment_ms_inner = uncached(_segment_ms)


def segment_rms_deg(q_est: np.ndarray, q_true: np.ndarray, mask: np.ndarray | None = None,
                    n_segments: int = N_SEGMENTS) -> tuple[np.ndarray, np.ndarray]:
    """RMS total attitude error (deg) and sample count of each of ``n_segments`` consecutive segments.

    ``q_est``, ``q_true``: (N, 4) quaternions (any sign, any order convention shared by both);
    ``mask``: (N,) samples to score (default all). Samples with non-finite truth are skipped.
    """
    q_est = np.ascontiguousarray(q_est, dtype=np.float64)
    q_true = np.ascontiguousarray(q_true, dtype=np.float64)
    if q_est.shape != q_true.shape or q_est.ndim != 2 or q_est.shape[1] != 4:
        raise ValueError(f"q_est {q_est.shape} and q_true {q_true.shape} must both be (N, 4)")
    if int(n_segments) < 2:
        raise ValueError(f"n_segments must be an integer >= 2, got {n_segments!r}")
    m = np.ones(q_true.shape[0], np.bool_) if mask is None else np.ascontiguousarray(mask, dtype=np.bool_)
    if m.shape != (q_true.shape[0],):
        raise ValueError(f"mask must have shape ({q_true.shape[0]},), got {m.shape}")
    out = np.empty(2 * int(n_segments))
    _segment_ms(q_est, q_true, m, out)
    ns = int(n_segments)
    return np.degrees(np.sqrt(out[:ns])), out[ns:].astype(np.int64)


def unbounded_growth(q_est: np.ndarray, q_true: np.ndarray, mask: np.ndarray | None = None,
                     limit_deg: float = GROWTH_LIMIT_DEG, ratio: float = GROWTH_RATIO) -> str:
    """Why the error grows without bound (module docstring), or ``""`` when it does not."""
    rms, count = segment_rms_deg(q_est, q_true, mask)
    return growth_verdict(rms, count, limit_deg, ratio)


def growth_verdict(rms: np.ndarray, count: np.ndarray, limit_deg: float = GROWTH_LIMIT_DEG,
                   ratio: float = GROWTH_RATIO) -> str:
    """:func:`unbounded_growth` from the segments' RMS errors (deg) and sample counts (as
    :func:`segment_rms_deg` returns them; the population kernels compute them with ``_segment_ms``)."""
    if count.min() < MIN_SEGMENT:
        return ""
    growing = bool(np.all(np.diff(rms) >= 0.0))
    if growing and rms[-1] >= ratio * rms[0] and rms[-1] > limit_deg:
        return ("attitude error grows without bound (RMS per quarter of the recording "
                + ", ".join(f"{v:.1f}" for v in rms) + f" deg; last > {limit_deg:g} deg and >= {ratio:g} x first)")
    return ""


def recording_failure(name: str, sums: Any, failed: str, growth: Callable[[], str]) -> str:
    """The evaluation's failure text after recording ``name``, one rule for the serial and the batch scoring.

    ``sums``: the recording's :class:`~objectives.attitude.fused_errors.ErrorSums`; ``failed``: the text so far
    (the first failing recording is the one named); ``growth()``: :func:`growth_verdict` of its segments, asked
    only when every sample is finite. A recording without a scored sample is a data error, not a failure.
    """
    if sums.n == 0:
        raise ValueError(f"{name}: no sample with finite truth inside the motion mask")
    if failed:
        return failed
    if sums.n_nonfinite:
        return f"filter diverged on {name}: {sums.n_nonfinite} non-finite samples"
    why = growth()
    return f"filter diverged on {name}: {why}" if why else ""
