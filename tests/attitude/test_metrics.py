"""Attitude metrics against hand-computed values and a per-sample loop reference."""

from __future__ import annotations

import math

import numpy as np
import pytest

from objectives.attitude import metrics as M
from objectives.attitude.quaternion import qexp_batch, quat_from_euler_zyx
from tests.reference import attitude_core_reference as ref

D = math.pi / 180


def eul(*rows):
    return quat_from_euler_zyx(np.array(rows, float))


def test_wrap_angle_half_open_interval():
    a = np.array([0.0, math.pi, -math.pi, 3 * math.pi, 2 * math.pi - 1e-3, -7.0, np.nan])
    w = M.wrap_angle(a)
    np.testing.assert_allclose(w[:6], [0, -math.pi, -math.pi, -math.pi, -1e-3, -7 + 2 * math.pi], atol=1e-12)
    assert np.isnan(w[6])
    x = np.random.default_rng(0).uniform(-50, 50, 10000)
    w = M.wrap_angle(x)
    assert np.all((w >= -math.pi) & (w < math.pi))
    np.testing.assert_allclose(np.cos(w), np.cos(x), atol=1e-12)
    assert isinstance(M.wrap_angle(4.0), float)


def test_euler_errors_wrap_and_sign():
    # truth yaw 179 deg, estimate -179 deg: a 2 deg error, e = true - est = -2 deg after wrapping
    e = M.euler_errors(eul([0, 0, -179 * D]), eul([0, 0, 179 * D]))
    np.testing.assert_allclose(e, [[0, 0, -2 * D]], atol=1e-12)
    e = M.euler_errors(eul([0.1, -0.2, 0.3]), eul([0.15, -0.1, 0.0]))
    np.testing.assert_allclose(e, [[0.05, 0.1, -0.3]], atol=1e-12)


def test_euler_errors_nan_truth_is_skipped_and_bad_estimate_is_pi():
    q_true = eul([0, 0, 0], [0, 0, 0], [0, 0, 0])
    q_true[1] = np.nan
    q_est = eul([0.1, 0, 0], [0, 0, 0], [0, 0, 0])
    q_est[2] = [np.inf, 0, 0, 0]
    e = M.euler_errors(q_est, q_true)
    np.testing.assert_allclose(e[0], [-0.1, 0, 0], atol=1e-12)
    assert np.isnan(e[1]).all()
    np.testing.assert_allclose(e[2], [math.pi] * 3)
    both_nan = M.euler_errors(np.full((1, 4), np.nan), np.full((1, 4), np.nan))
    assert np.isnan(both_nan).all()  # unknown truth wins: skipped, not counted as pi


def test_euler_stats_hand_computed():
    # roll errors -1, +3 deg; pitch 2, 2 deg; yaw 0, -4 deg (e = true - est); third sample NaN truth
    est = eul([1 * D, 0, 0], [-3 * D, 0, 4 * D], [0, 0, 0])
    true = eul([0, 2 * D, 0], [0, 2 * D, 0], [0, 0, 0])
    true[2] = np.nan
    s = M.euler_stats(est, true)
    assert s.n_samples == 2
    np.testing.assert_allclose(s.mse_deg2, [(1 + 9) / 2, 4, 16 / 2], rtol=1e-9)
    np.testing.assert_allclose(s.rmse_deg, np.sqrt([5, 4, 8]), rtol=1e-9)
    # sample std with N - 1: roll values -1, 3 -> mean 1, std sqrt((4 + 4)/1)
    np.testing.assert_allclose(s.std_deg, [math.sqrt(8), 0, math.sqrt(8)], rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(s.mean_deg, [1, 2, -2], atol=1e-9)
    np.testing.assert_allclose(s.mse_rad2, np.array([5, 4, 8]) * D * D, rtol=1e-9)
    d = s.as_dict()
    assert d["roll_rmse_deg"] == pytest.approx(math.sqrt(5)) and d["yaw_mse_deg2"] == pytest.approx(8)
    assert set(d) == {f"{a}_{m}" for a in ("roll", "pitch", "yaw")
                      for m in ("mse_deg2", "rmse_deg", "std_deg", "mean_deg")}
    # the mask drops the second sample
    s1 = M.euler_stats(est, true, mask=np.array([True, False, True]))
    assert s1.n_samples == 1
    np.testing.assert_allclose(s1.mse_deg2, [1, 4, 0], atol=1e-9)
    assert M.euler_stats(est, true, mask=np.zeros(3, bool)).n_samples == 0


def test_euler_mse_geomean_is_eq35():
    # scenario A: constant errors roll 0.1, pitch 0.2, yaw 0.3 rad; B: 0.01, 0.02, 0.04 with 2 samples,
    # one of them outside the mask (error 1 rad there) and one NaN-truth sample
    a_true = eul([0.1, 0.2, 0.3], [0.1, 0.2, 0.3])
    a_est = eul([0, 0, 0], [0, 0, 0])
    b_true = eul([0.01, 0.02, 0.04], [1.0, 1.0, 1.0], [0, 0, 0])
    b_true[2] = np.nan
    b_est = eul([0, 0, 0], [0, 0, 0], [0, 0, 0])
    mask_b = np.array([True, False, True])
    fa = (0.01 * 0.04 * 0.09) ** (1 / 3)
    assert M.euler_mse_geomean([(a_est, a_true)]) == pytest.approx(fa, rel=1e-9)
    prod = 0.01 * 0.04 * 0.09 * (0.01 ** 2 * 0.02 ** 2 * 0.04 ** 2)
    scen = [(a_est, a_true, None), (b_est, b_true, mask_b)]
    assert M.euler_mse_geomean(scen) == pytest.approx(prod ** (1 / 3), rel=1e-9)
    assert M.euler_mse_geomean(scen, normalize=True) == pytest.approx(prod ** (1 / 6), rel=1e-9)
    # weights are exponents; (1, 1, 0) drops yaw and takes the square root
    w = M.euler_mse_geomean([(a_est, a_true)], weights=(1, 1, 0))
    assert w == pytest.approx(math.sqrt(0.01 * 0.04), rel=1e-9)
    # lower errors give lower fitness
    assert M.euler_mse_geomean([(a_est, eul([0.05, 0.2, 0.3], [0.05, 0.2, 0.3]))]) < fa


def test_euler_mse_geomean_rejects_bad_input_and_counts_divergence():
    q = eul([0.1, 0.1, 0.1], [0.1, 0.1, 0.1])
    with pytest.raises(ValueError, match="scenario 1"):
        M.euler_mse_geomean([(q, q), (q, np.full((2, 4), np.nan))])
    with pytest.raises(ValueError, match="weights"):
        M.euler_mse_geomean([(q, q)], weights=(1, -1, 1))
    with pytest.raises(ValueError, match="at least one"):
        M.euler_mse_geomean([])
    est = q.copy()
    est[1] = np.nan
    f = M.euler_mse_geomean([(est, eul([0, 0, 0], [0, 0, 0]))])
    # each axis: errors -0.1 and pi (diverged) -> MSE (0.01 + pi^2) / 2; F = (MSE^3)^(1/3)
    assert f == pytest.approx((0.01 + math.pi ** 2) / 2, rel=1e-9)


def test_mse_1d_eq_3_18():
    est = np.array([0.0, 0.1, np.nan, 3.1, 0.5])
    true = np.array([0.2, 0.1, 0.0, -3.1, np.nan])
    # errors: 0.2, 0, pi (diverged), wrap(-6.2) = 2 pi - 6.2; NaN truth skipped
    expect = (0.04 + 0 + math.pi ** 2 + (2 * math.pi - 6.2) ** 2) / 4
    assert M.mse_1d(est, true) == pytest.approx(expect, rel=1e-12)
    assert M.mse_1d(est, true, mask=[True, True, False, False, True]) == pytest.approx(0.02, rel=1e-12)
    assert math.isnan(M.mse_1d(est[:1], np.array([np.nan])))
    with pytest.raises(ValueError, match="shape"):
        M.mse_1d(est, true[:3])


def test_broad_errors_hand_computed():
    ident = np.tile([1.0, 0, 0, 0], (4, 1))
    true = np.vstack([
        qexp_batch(np.array([0, 0, 30 * D])),   # pure heading error of 30 deg
        qexp_batch(np.array([40 * D, 0, 0])),   # pure inclination error of 40 deg
        [np.nan] * 4,                            # lost markers: skipped
        qexp_batch(np.array([0, 90 * D, 0])),   # outside motion: skipped
    ])
    motion = np.array([True, True, True, False])
    r = M.broad_errors(ident, true, motion)
    assert r.n_samples == 2
    assert r.total_rmse_deg == pytest.approx(math.sqrt((30 ** 2 + 40 ** 2) / 2), rel=1e-12)
    assert r.heading_rmse_deg == pytest.approx(math.sqrt(30 ** 2 / 2), rel=1e-12)
    assert r.inclination_rmse_deg == pytest.approx(math.sqrt(40 ** 2 / 2), rel=1e-12)
    est = ident.copy()
    est[1] = np.nan  # a diverged sample is a 180 deg error on every measure
    r = M.broad_errors(est, true, motion)
    assert r.total_rmse_deg == pytest.approx(math.sqrt((30 ** 2 + 180 ** 2) / 2), rel=1e-12)
    assert r.inclination_rmse_deg == pytest.approx(math.sqrt(180 ** 2 / 2), rel=1e-12)


def test_broad_errors_match_loop_reference():
    rng = np.random.default_rng(11)
    true = rng.normal(size=(300, 4))
    true /= np.linalg.norm(true, axis=1, keepdims=True)
    est = true + 0.2 * rng.normal(size=true.shape)  # unnormalised on purpose
    est[::37] *= -1  # sign flips are the same rotation
    true[5:9] = np.nan
    est[50] = np.nan
    motion = rng.random(300) > 0.3
    r = M.broad_errors(est, true, motion)
    np.testing.assert_allclose(
        [r.total_rmse_deg, r.heading_rmse_deg, r.inclination_rmse_deg],
        ref.broad_rmse_loop(est, true, motion), rtol=1e-10,
    )


def test_euler_errors_kernel_matches_numpy_composition():
    from objectives.attitude.quaternion import euler_zyx

    rng = np.random.default_rng(12)
    qt = rng.normal(size=(500, 4))
    qe = qt + 0.3 * rng.normal(size=qt.shape)
    expect = np.angle(np.exp(1j * (euler_zyx(qt) - euler_zyx(qe))))
    e = M.euler_errors(qe, qt)
    diff = np.abs(e - expect)
    assert np.all((diff < 1e-12) | (np.abs(diff - 2 * math.pi) < 1e-12))  # +-pi ends may differ
    assert np.all((e >= -math.pi) & (e < math.pi))
