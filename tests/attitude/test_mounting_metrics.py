"""Metrics that mean something at any mounting (issue #39, item 3): heading and inclination RMSE from
quaternions, a constant heading offset removed on request, and the Euler metrics' warning near pitch +-90 deg."""

from __future__ import annotations

import math

import numpy as np
import pytest

from objectives.attitude import metrics as M
from objectives.attitude.batch import evaluate_batch
from objectives.attitude.catalog import explain
from objectives.attitude.data.bench6dof import bench6dof
from objectives.attitude.data.recording import Recording
from objectives.attitude.data.synthetic import simulate_imu
from objectives.attitude.objective import FilterObjective
from objectives.attitude.quaternion import qmul_batch, quat_from_euler_zyx


def _z(psi: float) -> np.ndarray:
    return np.array([math.cos(psi / 2), 0.0, 0.0, math.sin(psi / 2)])


def _objective(metric: str, recs, **opts) -> FilterObjective:
    obj = FilterObjective("madgwick", [{"synthetic": {"generator": "bench6dof"}}], metric=metric,
                          metric_options=opts)  # accmag: the output depends on the IMU alone
    return obj.with_recordings(train=list(recs))


@pytest.fixture(scope="module")
def bench():
    return bench6dof(duration_s=20.0, rate_hz=200.0, seed=11, frame="ENU")


def test_heading_offset_closed_form_is_the_best_turn():
    """The closed form against a brute-force search of the same objective (scipy's bounded minimiser on a fine
    grid's best cell)."""
    from scipy.optimize import minimize_scalar

    rng = np.random.default_rng(3)
    q_true = quat_from_euler_zyx(rng.uniform(-1.5, 1.5, (300, 3)))
    noise = quat_from_euler_zyx(rng.normal(0, 0.05, (300, 3)))
    q_est = qmul_batch(qmul_batch(_z(0.7)[None], q_true), noise)
    q_est[::5] *= -1  # signs do not matter
    q_true[17] = np.nan  # skipped

    def cost(psi):
        r = qmul_batch(_z(psi)[None], np.nan_to_num(q_true))
        ok = np.isfinite(q_true).all(axis=1)
        return -float(np.sum(np.sum(r[ok] * q_est[ok], axis=1) ** 2))

    grid = np.linspace(-math.pi, math.pi, 721)
    g = grid[int(np.argmin([cost(p) for p in grid]))]
    best = minimize_scalar(cost, bounds=(g - 0.01, g + 0.01), method="bounded", options={"xatol": 1e-10}).x
    psi = M.heading_offset(q_est, q_true)
    assert psi == pytest.approx(best, abs=1e-6) and psi == pytest.approx(0.7, abs=0.01)
    mask = np.zeros(300, bool)
    assert M.heading_offset(q_est, q_true, mask) == 0.0


def test_removing_the_heading_offset_leaves_the_filter_error(bench):
    """A truth whose earth frame is turned by 30 deg scores with heading_offset: remove as the untouched truth
    does (the offset the filter's own heading error has is removed from both), and far worse without it."""
    turned = Recording(bench.name, bench.gyr, bench.acc, bench.mag, bench.dt, qmul_batch(_z(math.radians(30))[None],
                       bench.quat), frame="ENU", source="turned")
    for metric in ("broad_mean_rmse", "heading_rmse_mean", "euler_rmse_mean"):
        plain = _objective(metric, [bench], heading_offset="remove")({})
        moved = _objective(metric, [turned], heading_offset="remove")({})
        assert moved.fitness == pytest.approx(plain.fitness, rel=1e-6), metric
    assert _objective("heading_rmse_mean", [turned])({}).fitness > 20.0
    assert _objective("inclination_rmse_mean", [turned])({}).fitness == \
        pytest.approx(_objective("inclination_rmse_mean", [bench])({}).fitness, abs=1e-6)  # a turn about the vertical


def test_heading_and_inclination_metrics_are_broads_angles(bench):
    """The new metrics are means over recordings of BROAD's heading and inclination RMSE (metrics.broad_errors,
    the NumPy path, as the reference of the fused kernel's)."""
    other = bench6dof(duration_s=12.0, rate_hz=200.0, seed=12, frame="ENU")
    flt = _objective("heading_rmse_mean", [bench, other]).make_filter({})
    ref = [M.broad_errors(flt.run(r, q0="accmag"), r.quat, r.motion) for r in (bench, other)]
    for metric, key in (("heading_rmse_mean", "heading_rmse_deg"), ("inclination_rmse_mean", "inclination_rmse_deg")):
        got = _objective(metric, [bench, other])({}).fitness
        assert got == pytest.approx(np.mean([e.as_dict()[key] for e in ref]), rel=1e-9)
        cvar = _objective(metric, [bench, other], aggregate="worst_k", k=1)({}).fitness
        assert cvar == pytest.approx(max(e.as_dict()[key] for e in ref), rel=1e-9)


@pytest.mark.slow  # the batch kernel compiles when its cache is cold
def test_heading_offset_option_runs_serially_and_is_checked(bench):
    obj = _objective("broad_mean_rmse", [bench], heading_offset="remove")
    assert evaluate_batch(obj, [{}], 1) is None  # the truth depends on each candidate: no batch kernel
    assert evaluate_batch(_objective("broad_mean_rmse", [bench]), [{}], 1) is not None
    with pytest.raises(ValueError, match=r"objective\.metric_options\.heading_offset: expected none or remove"):
        _objective("broad_mean_rmse", [bench], heading_offset="yes")
    with pytest.raises(ValueError, match=r"heading_offset: mse_1d compares one tilt angle"):
        _objective("mse_1d", [bench], heading_offset="remove")
    doc = explain("inclination_rmse_mean")
    assert doc["unit"] == "deg" and [p["name"] for p in doc["params"]] == ["heading_offset"]


def _mounted(pitch_deg: float) -> Recording:
    t = np.arange(2000) * 0.01
    ang = np.column_stack([0.3 * np.sin(0.5 * t), np.radians(pitch_deg) + 0.05 * np.sin(0.7 * t), 0.5 * t])
    return simulate_imu(quat_from_euler_zyx(ang), 0.01, frame="ENU", name=f"pitch{pitch_deg:g}")


def test_euler_metrics_warn_near_pitch_90_naming_the_quaternion_metrics():
    up = _mounted(88.0)
    assert M.gimbal_share(up.quat) > 0.9 and M.gimbal_share(_mounted(0.0).quat) == 0.0
    assert M.gimbal_share(up.quat, mask=np.zeros(up.n, bool)) == 0.0
    for metric in ("euler_rmse_mean", "euler_mse_geomean"):
        (w,) = [x for x in _objective(metric, [up, _mounted(0.0)]).preflight() if "pitch +-90" in x]
        assert w.startswith("pitch88: ") and metric in w and "inclination_rmse_mean" in w
    for metric in ("broad_mean_rmse", "inclination_rmse_mean"):
        assert not any("pitch +-90" in x for x in _objective(metric, [up]).preflight())
    # the stated share: just under it no warning, just over it one
    n = up.n
    for share, warns in ((M.GIMBAL_SHARE * 0.9, False), (M.GIMBAL_SHARE * 1.1, True)):
        mix = np.where((np.arange(n) < share * n)[:, None], up.quat, _mounted(0.0).quat)
        assert bool(M.euler_lock_warning("r", "euler_rmse_mean", mix)) is warns
