"""UKF kernel building blocks against independent forms, and long runs against the literal reference.

The kernels evaluate the sigma points one per column with branch-free power series (vectorised loops)
and fall back to the exact scalar maps outside the series' range; these tests check both sides of
each fallback and a long disturbed recording end to end.
"""

import math

import numpy as np
import pytest

from objectives.attitude.filters.ukf import mean as um
from objectives.attitude.filters.ukf import run_ukf
from objectives.attitude.filters.ukf import scalar as sc
from tests.attitude.test_ukf import PARAMS, _disturbed, run_against_reference
from tests.reference import ukf_reference as ref


def _cloud(rng, center, m, spread):
    """(4, m) quaternions R2Q(d_j) * center with d_j ~ N(0, spread^2) per axis, random signs."""
    Y = np.empty((4, m))
    for j in range(m):
        Y[:, j] = ref.qplus(center, spread * rng.normal(size=3)) * rng.choice([-1.0, 1.0])
    return Y


@pytest.mark.parametrize("spread", [1e-6, 1e-3, 0.02, 0.3, 1.0])
def test_deviation_pass_series_and_exact_logarithm_agree(spread):
    """The vectorised series of eq. 1 equals the scalar logarithm; beyond 0.2 rad the pass is redone exactly."""
    rng = np.random.default_rng(1)
    c = ref.r2q(rng.normal(size=3))
    Y = _cloud(rng, c, 18, spread)
    D1, D2 = np.zeros((3, 18)), np.zeros((3, 18))
    s1 = um._dev_pass(Y, 18, 18, *c, D1, True)
    s2 = um._dev_pass(Y, 18, 18, *c, D2, False)
    Dref = np.array([ref.qminus(Y[:, j], c) for j in range(18)]).T
    assert np.allclose(D1, Dref, rtol=1e-12, atol=1e-15)
    assert np.allclose(D1, D2, rtol=1e-13, atol=1e-16)
    assert np.allclose(s1, s2, rtol=1e-12, atol=1e-16 * (1 + spread) ** 2)
    assert math.isclose(s1[0], Dref[0].sum(), rel_tol=1e-12, abs_tol=1e-15)


@pytest.mark.parametrize("spread", [1e-3, 0.01, 0.02, 0.1, 0.3])
def test_exact_pass_equals_the_scalar_logarithm_bit_for_bit(spread):
    """Without ``vector`` the pass gives the scalar logarithm's values exactly (its short series below
    ``|n|^2 = 1e-4``, its long one below 0.01, atan2 beyond: spreads around both thresholds), with 12 points
    padded to 16 columns whose values never enter the sums."""
    rng = np.random.default_rng(5)
    c = ref.r2q(rng.normal(size=3))
    for k in range(20):
        Y = np.empty((4, 16))
        Y[:, :12] = _cloud(rng, c, 12, spread)
        # padding as the kernel's (the centre: the series' side) or any (a far column sends the pass to the scalar form)
        Y[:, 12:] = c[:, None] if k % 2 == 0 else rng.normal(size=(4, 4))
        D = np.full((3, 16), np.nan)
        s = um._dev_pass(Y, 12, 16, *c, D, False)
        Dref = np.array([sc._qdiff(*Y[:, j], *c) for j in range(12)]).T
        assert np.array_equal(D[:, :12], Dref)
        sums = [0.0] * 9
        for dx, dy, dz in Dref.T:  # the same sums in the same order
            for i, v in enumerate((dx, dy, dz, dx * dx, dx * dy, dx * dz, dy * dy, dy * dz, dz * dz)):
                sums[i] += v
        assert list(s) == sums


@pytest.mark.parametrize("spread", [1e-4, 0.01, 0.3])
@pytest.mark.slow
def test_weighted_mean_matches_reference_mean(spread):
    rng = np.random.default_rng(2)
    c = ref.r2q(rng.normal(size=3))
    Y = _cloud(rng, c, 18, spread)
    for series in (True, False):
        D = np.zeros((3, 18))
        out = um._wmean_cov(Y, 18, 18, *c, D, series)
        mean = ref.wmean(list(Y.T), np.full(18, 1 / 18), c)
        assert abs(abs(np.dot(out[:4], mean)) - 1) < 1e-13
        dev = np.array([ref.qminus(Y[:, j], mean) for j in range(18)])
        cov = dev.T @ dev / 18
        got = np.array([[out[4], out[5], out[6]], [out[5], out[7], out[8]], [out[6], out[8], out[9]]])
        assert np.allclose(got, cov, rtol=1e-9, atol=1e-12 * spread ** 2)


@pytest.mark.parametrize("th", [0.0, 1e-5, 0.003, 0.2, 0.49])
def test_branch_free_exponential_equals_eq2(th):
    rng = np.random.default_rng(3)
    for _ in range(20):
        r = rng.normal(size=3)
        r *= th / max(np.linalg.norm(r), 1e-300)
        *q, th2 = um._r2q_series(*r)
        assert np.allclose(q, ref.r2q(r), rtol=0, atol=2e-16)
        assert math.isclose(th2, th * th, rel_tol=1e-12, abs_tol=1e-300)


def test_cholesky_with_reciprocal_diagonal():
    rng = np.random.default_rng(4)
    for scale in (1e-12, 1e-4, 1.0):
        A = rng.normal(size=(6, 6))
        A = scale * (A @ A.T + 0.1 * np.eye(6))
        L, rd = np.full((6, 6), np.nan), np.zeros(6)
        assert sc._chol(A, L, 6, rd)
        assert np.allclose(L, np.linalg.cholesky(A), rtol=1e-12, atol=1e-14 * math.sqrt(scale))
        assert np.array_equal(np.triu(L, 1), np.zeros((6, 6)))
        assert np.allclose(rd * np.diag(L), 1.0, rtol=1e-15)
    A[5, 5] = -1.0
    assert not sc._chol(A, L, 6, rd)


@pytest.mark.parametrize("robust", [False, True])
@pytest.mark.slow
def test_long_disturbed_run_matches_literal_reference(robust):
    """1000 samples at 40 Hz with eight magnetic and eight acceleration disturbances: the kernel and the
    plain-NumPy reference (eq. 28 evaluated literally, np.median for eq. 36) agree to 1e-10 rad throughout."""
    rec = _disturbed(n=1000, dt=0.025, seed=11)
    q0 = ref.qplus(rec.quat[0], np.array([0.05, -0.03, 0.1]))
    out = run_against_reference(rec, q0, dict(PARAMS, robust=robust, window=20, n_sigma=3.0))
    if robust:
        assert out["lam"].min() < 0.5  # the Hampel gain acted on the disturbances


@pytest.mark.slow
def test_fast_rotation_uses_the_exact_maps_and_matches_reference():
    """0.6 rad per sample (beyond the 0.5 rad series range of eq. 2) and a wide initial covariance (sigma points
    beyond the 0.2 rad series range of eq. 1): the fallbacks keep the kernel on the reference."""
    rec = _disturbed(n=300, dt=0.025, seed=5)
    gyr = rec.gyr.copy()
    gyr[40:60] += np.array([24.0, -5.0, 3.0])  # 0.6 rad per 25 ms sample
    kw = dict(PARAMS, robust=True, window=12, n_sigma=3.0, p0_att=0.4)
    assert np.max(np.linalg.norm(gyr, axis=1)) * rec.dt > 0.5
    out = run_ukf(gyr, rec.acc, rec.mag, rec.dt, rec.quat[0], **kw)
    q_ref, b_ref = ref.run_reference(gyr, rec.acc, rec.mag, rec.dt, rec.quat[0], **kw)
    diff = [np.linalg.norm(ref.qminus(a, b)) for a, b in zip(out["quat"], q_ref)]
    assert max(diff) < 1e-10
    assert np.max(np.abs(out["bias"] - b_ref)) < 1e-10
