"""The resampling of benchmarks/broad_rate.py: exact rational rate, anti-aliasing, truth at the nearest sample."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[2]
if str(REPO) not in sys.path:  # benchmarks/ is not an installed package
    sys.path.insert(0, str(REPO))

from benchmarks.broad_rate import BROAD_RATE_HZ, resample_recording  # noqa: E402
from objectives.attitude.data.recording import Recording  # noqa: E402


def _rec(n=2000):
    dt = 1.0 / BROAD_RATE_HZ
    t = np.arange(n) * dt
    slow = np.sin(2 * np.pi * 1.0 * t)  # 1 Hz: kept
    fast = np.sin(2 * np.pi * 80.0 * t)  # 80 Hz: above 50 Hz Nyquist of 100 Hz, removed
    gyr = np.stack([slow, slow + fast, np.zeros(n)], 1)
    acc = np.tile([0.0, 0.0, 9.81], (n, 1))
    quat = np.tile([1.0, 0.0, 0.0, 0.0], (n, 1))
    quat[:, 3] = t  # a marker of the time (not unit; only indexing is checked)
    motion = t > 1.0
    return Recording("r", gyr, acc, acc.copy(), dt, quat=quat, motion=motion), t


def test_rate_length_and_truth_alignment():
    rec, t = _rec()
    for rate in (100.0, 50.0):
        r = resample_recording(rec, rate)
        assert abs(r.dt - 1.0 / rate) < 1e-12
        assert abs(r.gyr.shape[0] - rec.gyr.shape[0] * rate / BROAD_RATE_HZ) <= 1
        tn = np.arange(r.gyr.shape[0]) * r.dt
        assert np.max(np.abs(r.quat[:, 3] - tn)) <= 0.5 * rec.dt + 1e-12  # truth of the nearest sample
        np.testing.assert_array_equal(r.motion, r.quat[:, 3] > 1.0)  # the mask of the same sample


def test_anti_aliasing_keeps_slow_and_removes_fast_content():
    rec, _ = _rec()
    r = resample_recording(rec, 100.0)
    tn = np.arange(r.gyr.shape[0]) * r.dt
    inner = slice(20, -20)  # away from the ends
    np.testing.assert_allclose(r.gyr[inner, 0], np.sin(2 * np.pi * tn[inner]), atol=2e-3)
    np.testing.assert_allclose(r.gyr[inner, 1], r.gyr[inner, 0], atol=2e-2)  # the 80 Hz tone is gone
    np.testing.assert_allclose(r.acc[:, 2], 9.81, atol=1e-3)  # constants kept to the ends (polyphase ripple 5e-5)
