"""An attitude error growing without bound is a recorded failure (objectives.attitude.divergence)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from objectives.attitude.data.recording import Recording
from objectives.attitude.divergence import GROWTH_LIMIT_DEG, segment_rms_deg, unbounded_growth
from objectives.attitude.objective import FilterObjective


def _about_z(angle_rad: np.ndarray) -> np.ndarray:
    return np.stack([np.cos(angle_rad / 2), 0 * angle_rad, 0 * angle_rad, np.sin(angle_rad / 2)], axis=1)


def test_segment_rms_of_a_linear_drift_matches_the_closed_form():
    n = 40_000
    t = np.arange(n) / n                        # time in units of the recording
    theta_end = math.radians(120.0)
    est, truth = _about_z(theta_end * t), _about_z(0 * t)
    rms, count = segment_rms_deg(est, truth)
    assert list(count) == [n // 4] * 4
    # RMS of a linear ramp a*t over [t0, t1]: a sqrt((t1^3 - t0^3) / (3 (t1 - t0)))
    edges = np.linspace(0, 1, 5)
    closed = [120.0 * math.sqrt((b ** 3 - a ** 3) / (3 * (b - a))) for a, b in zip(edges[:-1], edges[1:])]
    np.testing.assert_allclose(rms, closed, rtol=1e-3)
    assert "grows without bound" in unbounded_growth(est, truth)


@pytest.mark.parametrize("error_deg, flagged", [
    (lambda t: 120.0 * t, True),                    # steady drift to 120 deg
    (lambda t: 50.0 * t, False),                    # drift, but ends below the 60 deg limit
    (lambda t: 90.0 + 0 * t, False),                # constant offset: wrong, but not growing
    (lambda t: 150.0 * np.sin(np.pi * t), False),   # grows, then recovers
    (lambda t: 40.0 + 40.0 * t, False),             # ends above the limit but only 1.4 x the first quarter
])
def test_only_steady_growth_past_the_limit_is_flagged(error_deg, flagged):
    t = np.linspace(0, 1, 4000)
    est = _about_z(np.radians(error_deg(t)))
    assert bool(unbounded_growth(est, _about_z(0 * t))) is flagged


def test_mask_and_non_finite_estimates():
    t = np.linspace(0, 1, 4000)
    est, truth = _about_z(np.radians(120.0 * t)), _about_z(0 * t)
    mask = t < 0.5                                  # the scored part ends at 60 deg: not past the limit
    assert unbounded_growth(est, truth, mask) == ""
    est[-500:] = np.nan                             # non-finite counts as 180 deg
    rms, _ = segment_rms_deg(est, truth)
    assert rms[-1] > rms[-2] > GROWTH_LIMIT_DEG
    assert unbounded_growth(est[:20], truth[:20]) == ""  # too few samples to judge
    with pytest.raises(ValueError, match="mask must have shape"):
        segment_rms_deg(est, truth, mask[:10])


def _biased_recording(bias_rps: float, duration_s: float = 60.0, rate_hz: float = 100.0) -> Recording:
    n = int(duration_s * rate_hz)
    gyr = np.tile([0.0, 0.0, bias_rps], (n, 1))     # at rest, a gyro bias about the vertical
    acc = np.tile([0.0, 0.0, 9.81], (n, 1))
    mag = np.tile([0.0, 20.0, -40.0], (n, 1))
    quat = np.tile([1.0, 0.0, 0.0, 0.0], (n, 1))
    return Recording("biased", gyr, acc, mag, 1.0 / rate_hz, quat, np.ones(n, bool))


def test_filter_objective_records_a_runaway_filter_as_failed():
    obj = FilterObjective("madgwick", [{"synthetic": {"generator": "bench6dof", "duration_s": 1, "seed": 1}}],
                          metric="broad_mean_rmse", q0="truth")
    obj = obj.with_recordings(train=[_biased_recording(0.03)])  # 0.03 rad/s for 60 s: 103 deg of heading
    pure = obj({"beta": 0.0})                         # gyro integration only: the heading drifts away
    assert pure.status != "ok" and "grows without bound" in pure.error and "biased" in pure.error
    corrected = obj({"beta": 0.1})                    # the magnetometer holds the heading: bounded
    assert corrected.status == "ok" and corrected.fitness < 10.0
