"""Error metrics of attitude estimates against ground truth.

Every metric skips samples whose truth is NaN (and, for BROAD metrics, samples outside the motion
mask); they never propagate NaN from the truth.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["BroadErrors", "broad_errors", "broad_error_angles"]


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


def broad_error_angles(q_est: np.ndarray, q_true: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per-sample total, heading and inclination error (rad) of BROAD's example code.

    ``q_err = q_est * conj(q_true)`` (earth frame, z up); total ``2 acos(|w|)``, heading
    ``2 atan(|z / w|)``, inclination ``2 acos(sqrt(w^2 + z^2))``. Rows with NaN stay NaN.
    """
    e, t = np.asarray(q_est, float), np.asarray(q_true, float)
    w1, x1, y1, z1 = e[:, 0], e[:, 1], e[:, 2], e[:, 3]
    w2, x2, y2, z2 = t[:, 0], -t[:, 1], -t[:, 2], -t[:, 3]
    w = w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2
    z = w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2
    x = w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2
    y = w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2
    norm = np.sqrt(w * w + x * x + y * y + z * z)
    w, z = w / norm, z / norm
    with np.errstate(invalid="ignore", divide="ignore"):
        total = 2.0 * np.arccos(np.clip(np.abs(w), 0.0, 1.0))
        heading = 2.0 * np.arctan(np.abs(z / w))
        incl = 2.0 * np.arccos(np.clip(np.sqrt(w * w + z * z), 0.0, 1.0))
    return total, heading, incl


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
