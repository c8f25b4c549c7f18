"""The kf1d population kernel's mse_1d equals objectives.attitude.metrics.mse_1d bit for bit."""

import numpy as np
import pytest

from objectives.attitude.batch import _mse_1d_kernel, _wrap_angle
from objectives.attitude.metrics import mse_1d, wrap_angle


def test_wrap_angle_kernel_equals_numpy_with_signs_and_edges():
    rng = np.random.default_rng(0)
    x = np.concatenate([rng.standard_normal(20_000) * 10.0 ** rng.uniform(-12, 3, 20_000),
                        [0.0, -0.0, np.pi, -np.pi, 3 * np.pi, -3 * np.pi, 2 * np.pi, -2 * np.pi, 1e300, -1e-300,
                         np.nan, np.inf]])
    with np.errstate(invalid="ignore"):
        ref = wrap_angle(x)
    got = np.array([_wrap_angle(v) for v in x])
    assert np.array_equal(got, ref, equal_nan=True)
    assert np.array_equal(np.signbit(got), np.signbit(ref))
    assert np.all((got[np.isfinite(got)] >= -np.pi) & (got[np.isfinite(got)] < np.pi))


@pytest.mark.slow
def test_mse_1d_kernel_equals_numpy_with_gaps_masks_and_non_finite_estimates():
    rng = np.random.default_rng(1)
    for _ in range(200):
        n = int(rng.integers(1, 5000))
        true = rng.uniform(-4.0, 4.0, n)
        est = true + rng.standard_normal(n) * rng.uniform(0.0, 3.0)
        est[rng.random(n) < 0.01] = np.nan
        true[rng.random(n) < 0.01] = np.nan
        mask = rng.random(n) < 0.9
        ref, got = mse_1d(est, true, mask), _mse_1d_kernel(est, true, mask, np.empty(n))
        assert got == ref or (np.isnan(ref) and np.isnan(got))
    assert np.isnan(_mse_1d_kernel(np.zeros(3), np.zeros(3), np.zeros(3, dtype=bool), np.empty(3)))
