"""Error metrics of attitude estimates against ground truth.

Every metric skips samples whose truth is NaN (and samples outside the motion mask where one is
given); they never propagate NaN from the truth. Estimates that are not finite (a diverged filter)
count as the maximal error (pi rad, 180 deg) and are never dropped, so diverging cannot look good.

Units: the Euler metrics of the FAEKF paper (Table 2, eq. 35) are computed from errors in rad;
:class:`EulerStats` reports them in deg / deg^2 (names carry the unit), :func:`euler_mse_geomean`
in rad^2 as the paper's Table 2 does.

Mounting: the BROAD error angles (total, heading, inclination; :func:`broad_error_angles`) come from the error
quaternion and mean the same at any orientation; Euler angles lose roll and yaw near pitch +-90 deg (an IMU
mounted x-up), where their errors mean nothing. :func:`gimbal_share` measures how much of a recording is there
and :func:`euler_lock_warning` says so for the Euler metrics. A truth whose earth frame differs from the filter's
by a constant heading (a motion-capture frame, a truth relative to its start pose after tilt alignment) is
compared after :func:`remove_heading_offset` (metric option ``heading_offset: remove``).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from objectives.attitude.quaternion import qconj_batch, qmul_batch

__all__ = [
    "BroadErrors", "broad_errors", "BroadErrorAngles", "broad_error_angles", "wrap_angle", "euler_errors", "EulerStats",
    "euler_stats", "euler_mse_geomean", "mse_1d", "heading_offset", "remove_heading_offset", "gimbal_share",
    "euler_lock_warning", "EULER_METRICS", "GIMBAL_WITHIN_DEG", "GIMBAL_SHARE",
]

#: the metrics computed from Euler angles (meaningless near pitch +-90 deg)
EULER_METRICS = ("euler_mse_geomean", "euler_rmse_mean")
#: a truth sample within this many degrees of pitch +-90 deg is in (or near) gimbal lock
GIMBAL_WITHIN_DEG = 10.0
#: share of a recording's scored samples near gimbal lock above which the Euler metrics warn
GIMBAL_SHARE = 0.05


@dataclass(frozen=True)
class BroadErrors:
    """BROAD error metric: RMSE in degrees over the motion samples with valid truth."""

    total_rmse_deg: float
    heading_rmse_deg: float
    inclination_rmse_deg: float
    n_samples: int

    def as_dict(self) -> dict[str, float]:
        return {
            "total_rmse_deg": self.total_rmse_deg,
            "heading_rmse_deg": self.heading_rmse_deg,
            "inclination_rmse_deg": self.inclination_rmse_deg,
        }


class BroadErrorAngles(NamedTuple):
    """Per-sample BROAD error angles, rad, each (N,); unpacks as ``total, heading, inclination``."""

    total_rad: np.ndarray
    heading_rad: np.ndarray
    inclination_rad: np.ndarray


def broad_error_angles(q_est: np.ndarray, q_true: np.ndarray) -> BroadErrorAngles:
    """Per-sample total, heading and inclination error (rad) of BROAD's example code.

    ``q_err = q_est * conj(q_true)`` (earth frame, z up); total ``2 acos(|w|)``, heading
    ``2 atan(|z / w|)``, inclination ``2 acos(sqrt(w^2 + z^2))``. Rows with NaN stay NaN.
    """
    q_err = qmul_batch(q_est, qconj_batch(np.asarray(q_true, float)))
    w, z = q_err[:, 0], q_err[:, 3]
    norm = np.linalg.norm(q_err, axis=1)
    w, z = w / norm, z / norm
    with np.errstate(invalid="ignore", divide="ignore"):
        total = 2.0 * np.arccos(np.clip(np.abs(w), 0.0, 1.0))
        heading = 2.0 * np.arctan(np.abs(z / w))
        incl = 2.0 * np.arccos(np.clip(np.sqrt(w * w + z * z), 0.0, 1.0))
    return BroadErrorAngles(total, heading, incl)


def broad_errors(q_est: np.ndarray, q_true: np.ndarray, motion: np.ndarray | None = None) -> BroadErrors:
    """RMSE (deg) of the BROAD error angles over ``motion`` samples whose truth is finite.

    Samples where the estimate is not finite count as 180 deg errors (a diverged filter must not
    look good by dropping samples).
    """
    q_est = np.asarray(q_est, float)
    q_true = np.asarray(q_true, float)
    valid = np.isfinite(q_true).all(axis=1)
    if motion is not None:
        valid &= np.asarray(motion, bool)
    n = int(valid.sum())
    if n == 0:
        nan = float("nan")
        return BroadErrors(nan, nan, nan, 0)
    tot, head, inc = broad_error_angles(q_est[valid], q_true[valid])
    out = []
    for a in (tot, head, inc):
        a = np.where(np.isfinite(a), a, np.pi)
        out.append(float(np.degrees(np.sqrt(np.mean(a * a)))))
    return BroadErrors(out[0], out[1], out[2], n)


# ------------------------------------------------------------------------------------------------
# Euler-angle metrics (the FAEKF paper, Table 2 and eq. 35; the thesis, eq. 3.18)
# ------------------------------------------------------------------------------------------------

_AXES = ("roll", "pitch", "yaw")


def wrap_angle(a):
    """Angle(s) in rad wrapped to ``[-pi, pi)``; NaN stays NaN. Scalar in, float out."""
    out = np.mod(np.asarray(a, dtype=float) + np.pi, 2.0 * np.pi) - np.pi
    # np.mod may return 2 pi for tiny negative inputs (rounding); keep the half-open interval
    out = np.where(out >= np.pi, out - 2.0 * np.pi, out)
    return float(out) if np.ndim(out) == 0 else out


def _quat_rows(q, what: str) -> np.ndarray:
    q = np.asarray(q, dtype=float)
    if q.ndim != 2 or q.shape[1] != 4:
        raise ValueError(f"{what} must have shape (N, 4), got {q.shape}")
    return q


def euler_errors(q_est: np.ndarray, q_true: np.ndarray) -> np.ndarray:
    """Roll, pitch and yaw errors ``e = true - estimate`` (the FAEKF paper, section 5.2), rad.

    Both inputs are sensor-to-earth quaternions in the same earth frame; angles are those of
    :func:`objectives.attitude.quaternion.euler_zyx` and each difference is wrapped to
    ``[-pi, pi)``, so 179 deg vs -179 deg is a 2 deg error.

    Parameters
    ----------
    q_est, q_true : ndarray (N, 4)

    Returns
    -------
    ndarray (N, 3)
        Errors in rad. Rows where the truth is not finite are NaN (metrics skip them); rows where
        the truth is finite but the estimate is not are ``pi`` on every axis (maximal error).
    """
    from objectives.attitude.quaternion import _euler_error_kernel

    q_est = _quat_rows(q_est, "q_est")
    q_true = _quat_rows(q_true, "q_true")
    if q_est.shape != q_true.shape:
        raise ValueError(f"q_est {q_est.shape} and q_true {q_true.shape} differ in shape")
    e = np.empty((q_true.shape[0], 3))
    _euler_error_kernel(np.ascontiguousarray(q_est), np.ascontiguousarray(q_true), e)
    return e


def _valid_mask(n: int, truth_ok: np.ndarray, mask) -> np.ndarray:
    valid = truth_ok.copy()
    if mask is not None:
        m = np.asarray(mask, dtype=bool).ravel()
        if m.shape[0] != n:
            raise ValueError(f"mask has {m.shape[0]} samples, expected {n}")
        valid &= m
    return valid


@dataclass(frozen=True)
class EulerStats:
    """Per-axis statistics of the Euler errors (order roll, pitch, yaw), as in the FAEKF paper's Table 2.

    Attributes
    ----------
    mse_deg2 : ndarray (3,)
        Mean squared error, deg^2 (Table 2 reports rad^2: ``mse_rad2``).
    rmse_deg : ndarray (3,)
        Root mean squared error, deg.
    std_deg : ndarray (3,)
        Standard deviation of the error about its mean, deg, with ``N - 1`` in the denominator
        (MATLAB's ``std``, the tool of the paper); ``mse = std^2 (N-1)/N + mean^2``.
    mean_deg : ndarray (3,)
        Mean error (bias), deg.
    n_samples : int
        Samples used (finite truth and inside the mask).
    """

    mse_deg2: np.ndarray
    rmse_deg: np.ndarray
    std_deg: np.ndarray
    mean_deg: np.ndarray
    n_samples: int

    @property
    def mse_rad2(self) -> np.ndarray:
        """MSE in rad^2, the unit of the paper's Table 2 and of eq. 35."""
        return self.mse_deg2 * (np.pi / 180.0) ** 2

    @property
    def std_rad(self) -> np.ndarray:
        return np.radians(self.std_deg)

    def as_dict(self) -> dict[str, float]:
        """Flat names: ``roll_mse_deg2``, ``roll_rmse_deg``, ``roll_std_deg``, ``roll_mean_deg``, ..."""
        out: dict[str, float] = {}
        for i, ax in enumerate(_AXES):
            out[f"{ax}_mse_deg2"] = float(self.mse_deg2[i])
            out[f"{ax}_rmse_deg"] = float(self.rmse_deg[i])
            out[f"{ax}_std_deg"] = float(self.std_deg[i])
            out[f"{ax}_mean_deg"] = float(self.mean_deg[i])
        return out


def euler_stats(q_est: np.ndarray, q_true: np.ndarray, mask: np.ndarray | None = None) -> EulerStats:
    """Per-axis MSE, RMSE, STD and mean of the Euler errors (:func:`euler_errors`), in deg.

    Parameters
    ----------
    q_est, q_true : ndarray (N, 4)
        Sensor-to-earth quaternions in the same frame; NaN truth rows are skipped.
    mask : ndarray (N,) bool, optional
        Samples to use (e.g. ``Recording.motion``); default all.

    Returns
    -------
    EulerStats
        With NaN arrays and ``n_samples = 0`` when no sample is valid; STD is NaN for one sample.
    """
    e = euler_errors(q_est, q_true)
    valid = _valid_mask(e.shape[0], np.isfinite(e).all(axis=1), mask)
    n = int(valid.sum())
    if n == 0:
        nan = np.full(3, np.nan)
        return EulerStats(nan, nan.copy(), nan.copy(), nan.copy(), 0)
    ed = np.degrees(e[valid])
    mse = np.mean(ed * ed, axis=0)
    std = np.std(ed, axis=0, ddof=1) if n > 1 else np.full(3, np.nan)
    return EulerStats(mse, np.sqrt(mse), std, ed.mean(axis=0), n)


def _scenario_mse_rad2(item, j: int) -> np.ndarray:
    if not isinstance(item, (tuple, list)) or len(item) not in (2, 3):
        raise ValueError(
            f"scenario {j}: expected (q_est, q_true) or (q_est, q_true, mask), got {type(item).__name__}"
        )
    q_est, q_true = item[0], item[1]
    mask = item[2] if len(item) == 3 else None
    e = euler_errors(q_est, q_true)
    valid = _valid_mask(e.shape[0], np.isfinite(e).all(axis=1), mask)
    if not valid.any():
        raise ValueError(f"scenario {j}: no sample with finite truth inside the mask")
    ev = e[valid]
    return np.mean(ev * ev, axis=0)


def euler_mse_geomean(
    scenarios: Sequence, weights: Sequence[float] = (1.0, 1.0, 1.0), normalize: bool = False
) -> float:
    """Fitness of the FAEKF paper, eq. 35: cube root of the product of the per-axis MSEs over scenarios.

    ``F = ( prod_j MSE_roll,j * MSE_pitch,j * MSE_yaw,j ) ^ (1/3)`` with ``MSE = sum_k e_k^2 / N_j``
    over the valid samples of scenario ``j`` and errors in **rad** (so ``F`` is in rad^2 for one
    scenario, as the paper's Table 2). For one scenario it is the geometric mean of the three
    MSEs; the paper keeps the cube root for ``k_sce`` scenarios, which makes ``F`` scale like
    ``MSE^k_sce``: that does not change which parameters are best, but values for different numbers
    of scenarios are not comparable. ``normalize=True`` takes the ``1/(3 k_sce)`` root instead (the
    geometric mean of all MSEs, in rad^2), a documented extension, not the paper's definition.

    Parameters
    ----------
    scenarios : sequence of (q_est, q_true) or (q_est, q_true, mask)
        One entry per scenario: (N_j, 4) quaternions and an optional (N_j,) bool mask.
    weights : (3,) floats >= 0, default (1, 1, 1)
        Exponents of the roll, pitch, yaw MSEs (a weighted geometric mean); the root becomes
        ``1/sum(weights)`` (``1/(k_sce sum(weights))`` with ``normalize``), so (1, 1, 1) is eq. 35.
    normalize : bool
        See above.

    Returns
    -------
    float
        ``F`` >= 0 (0 if some weighted MSE is exactly 0). Non-finite estimates count as pi errors.

    Raises
    ------
    ValueError
        No scenario, bad weights, or a scenario with no valid sample (names its index).
    """
    w = np.asarray(weights, dtype=float)
    if w.shape != (3,) or not np.all(np.isfinite(w)) or np.any(w < 0) or w.sum() <= 0:
        raise ValueError(f"weights must be 3 finite numbers >= 0 with a positive sum, got {weights!r}")
    scenarios = list(scenarios)
    if not scenarios:
        raise ValueError("euler_mse_geomean needs at least one scenario")
    log_sum = 0.0
    for j, item in enumerate(scenarios):
        mse = _scenario_mse_rad2(item, j)
        with np.errstate(divide="ignore"):
            logs = np.where(w > 0, np.log(mse), 0.0)
        log_sum += float(np.sum(w * logs))
    root = w.sum() * (len(scenarios) if normalize else 1)
    return float(np.exp(log_sum / root))


def mse_1d(angle_est: np.ndarray, angle_true: np.ndarray, mask: np.ndarray | None = None) -> float:
    """Mean squared error of one angle, the thesis eq. 3.18: ``F = (1/N) sum_k (theta_k - theta_hat_k)^2``.

    Parameters
    ----------
    angle_est, angle_true : ndarray (N,)
        Angles in rad (e.g. the tilt of the 1-D Kalman filter of thesis 3.1). The difference is
        wrapped to ``[-pi, pi)`` (no effect for the small tilt angles of the thesis).
    mask : ndarray (N,) bool, optional
        Samples to use.

    Returns
    -------
    float
        MSE in rad^2 over the samples with finite truth inside the mask (NaN if none); samples with
        a non-finite estimate count as pi errors.
    """
    est = np.asarray(angle_est, dtype=float).ravel()
    true = np.asarray(angle_true, dtype=float).ravel()
    if est.shape != true.shape:
        raise ValueError(f"angle_est {est.shape} and angle_true {true.shape} differ in shape")
    valid = _valid_mask(true.shape[0], np.isfinite(true), mask)
    if not valid.any():
        return float("nan")
    with np.errstate(invalid="ignore"):
        e = wrap_angle(true[valid] - est[valid])
    e = np.where(np.isfinite(est[valid]), e, np.pi)
    return float(np.mean(e * e))


# ------------------------------------------------------------------------------------------------
# mounting: a constant heading offset of the truth frame, gimbal lock of the Euler angles
# ------------------------------------------------------------------------------------------------

def _z_turn(q: np.ndarray) -> np.ndarray:
    """``e_z * q`` row by row for (N, 4) quaternions, ``e_z = (0, 0, 0, 1)``: ``(-z, -y, x, w)``."""
    return np.stack([-q[:, 3], -q[:, 2], q[:, 1], q[:, 0]], axis=1)


def heading_offset(q_est: np.ndarray, q_true: np.ndarray, mask: np.ndarray | None = None) -> float:
    """The constant heading offset (rad) of the truth's earth frame from the estimate's.

    The turn ``r = (cos(psi/2), 0, 0, sin(psi/2))`` about the earth's z axis that brings ``r * q_true`` closest
    to ``q_est``: it maximises ``sum_k (q_est,k . r q_true,k)^2`` (the sum of squared chordal quaternion
    distances is minimal; squared, so ``q`` and ``-q`` count alike). With ``a_k = q_true,k . q_est,k`` and
    ``b_k = (e_z q_true,k) . q_est,k`` the sum is ``v^T M v`` for ``v = (cos(psi/2), sin(psi/2))`` and
    ``M = [[sum a^2, sum ab], [sum ab, sum b^2]]``: ``v`` is its principal eigenvector, in closed form.

    Parameters
    ----------
    q_est, q_true : ndarray (N, 4)
        Sensor-to-earth quaternions; rows where either is not finite (or outside ``mask``) are left out.
    mask : ndarray (N,) bool, optional

    Returns
    -------
    float
        ``psi`` in ``[-pi, pi)``, counter-clockwise about the earth's z axis; 0 when no row is valid.
    """
    q_est = _quat_rows(q_est, "q_est")
    q_true = _quat_rows(q_true, "q_true")
    ok = _valid_mask(q_true.shape[0], np.isfinite(q_true).all(axis=1) & np.isfinite(q_est).all(axis=1), mask)
    if not ok.any():
        return 0.0
    e, t = q_est[ok], q_true[ok]
    a = np.sum(t * e, axis=1)
    b = np.sum(_z_turn(t) * e, axis=1)
    m = np.array([[a @ a, a @ b], [a @ b, b @ b]])
    w, v = np.linalg.eigh(m)
    c, s = v[:, int(np.argmax(w))]
    return wrap_angle(2.0 * np.arctan2(s, c))


def remove_heading_offset(q_est: np.ndarray, q_true: np.ndarray, mask: np.ndarray | None = None) -> np.ndarray:
    """``q_true`` (N, 4) turned about the earth's z axis by its :func:`heading_offset` from ``q_est``: the truth
    the metrics compare with under ``heading_offset: remove``."""
    psi = heading_offset(q_est, q_true, mask)
    q_true = np.asarray(q_true, dtype=float)
    return np.cos(psi / 2.0) * q_true + np.sin(psi / 2.0) * _z_turn(q_true)


def gimbal_share(q_true: np.ndarray, mask: np.ndarray | None = None, within_deg: float = GIMBAL_WITHIN_DEG) -> float:
    """Share of the samples (finite truth, inside ``mask``) whose true pitch is within ``within_deg`` of +-90 deg
    (0 when there is none)."""
    from objectives.attitude.quaternion import euler_zyx

    q = _quat_rows(q_true, "q_true")
    ok = _valid_mask(q.shape[0], np.isfinite(q).all(axis=1), mask)
    if not ok.any():
        return 0.0
    pitch = euler_zyx(np.ascontiguousarray(q[ok]))[:, 1]
    return float(np.mean(np.abs(pitch) > np.radians(90.0 - within_deg)))


def euler_lock_warning(name: str, metric: str, q_true: np.ndarray | None, mask: np.ndarray | None = None) -> list[str]:
    """One line when ``metric`` is an Euler metric and more than :data:`GIMBAL_SHARE` of the recording's scored
    samples are within :data:`GIMBAL_WITHIN_DEG` of pitch +-90 deg, naming the quaternion metrics."""
    if metric not in EULER_METRICS or q_true is None:
        return []
    share = gimbal_share(q_true, mask)
    if share <= GIMBAL_SHARE:
        return []
    return [f"{name}: {100 * share:.3g} % of the scored samples are within {GIMBAL_WITHIN_DEG:g} deg of pitch +-90 "
            f"deg, where roll and yaw are not defined and {metric} means little; score it with "
            "inclination_rmse_mean, heading_rmse_mean or broad_mean_rmse (from quaternions, the same at any "
            "mounting)"]
