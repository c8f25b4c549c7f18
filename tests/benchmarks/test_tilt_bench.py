"""benchmarks.tilt_bench: the error split by condition and the damping bound docs/tilt-bench.md relies on."""

from __future__ import annotations

import math

import numpy as np
import pytest
import yaml

from benchmarks import tilt_bench

scipy_linalg = pytest.importorskip("scipy.linalg")


def _steady_gains(rho: float, q00: float, q11: float, dt: float) -> tuple[float, float]:
    """Steady-state Kalman gain of eqs. 3.9-3.13 as loop gains per second: ``(K1, K2)`` of ``s^2 + K1 s + K2``."""
    phi = np.array([[1.0, -dt], [0.0, 1.0]])
    h = np.array([[1.0, 0.0]])
    p = scipy_linalg.solve_discrete_are(phi.T, h.T, np.diag([q00, q11]), np.array([[rho]]))
    g = p @ h.T / (h @ p @ h.T + rho)
    return g[0, 0] / dt, -g[1, 0] / dt  # b_k+1 = b_k + G1 r and theta_k+1 = theta_k - Ts b_k: theta'' = -(G1 / Ts) r


@pytest.mark.parametrize("seed", range(4))
def test_kf_loop_damping_is_at_least_one_over_sqrt2(seed):
    """docs/tilt-bench.md section 4: whatever rho, q00, q11 (and so any fuzzy scale of R), the KF's loop
    ``s^2 + K1 s + K2`` has damping >= 1/sqrt(2), with equality as q00 -> 0 (continuous Riccati:
    ``K1^2 = q00 / (rho Ts^2) + 2 K2`` with the per-sample variances of eq. 3.17)."""
    rng = np.random.default_rng(seed)
    dt = 1 / 800
    for _ in range(20):
        rho = 10 ** rng.uniform(-3, 0)
        q00 = 10 ** rng.uniform(-11, -6)
        q11 = 10 ** rng.uniform(-13, -8)
        k1, k2 = _steady_gains(rho, q00, q11, dt)
        zeta = k1 / (2 * math.sqrt(k2))
        assert zeta >= 1 / math.sqrt(2) * (1 - 1e-2), (rho, q00, q11, zeta)
        np.testing.assert_allclose(k1 ** 2, q00 / (rho * dt ** 2) + 2 * k2, rtol=0.05)
    k1, k2 = _steady_gains(0.4, 1e-16, 1e-11, dt)
    assert math.isclose(k1 / (2 * math.sqrt(k2)), 1 / math.sqrt(2), rel_tol=1e-2)


def _tiny_run(tmp_path, filter_name: str, params: dict) -> tuple:
    data = {"train": [{"synthetic": {"generator": "tilt1d", "profile": "thesis", "duration_s": 8, "seed": 1}}],
            "test": [{"synthetic": {"generator": "tilt1d", "profile": "thesis", "duration_s": 8, "seed": s}}
                     for s in (2, 3)]}
    cfg = {"name": "t", "seed": 1, "objective": {"kind": "filter", "filter": filter_name, "data": data,
                                                  "metric": "mse_1d"},
           "optimizer": {"method": "pso", "population": 2, "generations": 1}}
    (tmp_path / "config.yaml").write_text(yaml.safe_dump(cfg))
    objective = tilt_bench._objective(tmp_path)
    full = {**objective.default_params(), **params}
    fit = objective.score(full, "test").fitness
    (tmp_path / "best.yaml").write_text(yaml.safe_dump({"params": full, "evaluation": {"test_fitness": fit}}))
    return objective, fit


def test_condition_errors_split_the_runs_own_error(tmp_path):
    """Per recording the rerun equals the objective's fitness (mean over recordings); the phases partition
    the samples, so their shares weight the per-phase MSEs back to the pooled MSE."""
    _, fit = _tiny_run(tmp_path, "akf1d", {"rho": 0.2, "q00": 1e-7, "q11": 1e-11})
    r = tilt_bench.condition_errors(tmp_path)
    assert math.isclose(np.mean(r["per_recording"]), fit * tilt_bench.DEG2, rel_tol=1e-9)
    shares = np.array(list(r["share"].values()))
    assert math.isclose(shares.sum(), 1.0, rel_tol=1e-12)
    pooled = sum(r["share"][p] * r["per_phase"][p] for p in r["share"] if r["share"][p] > 0)
    assert math.isclose(pooled, np.mean(r["per_recording"]), rel_tol=1e-9)  # equal lengths: pooled = mean
    assert set(r["K_per_phase"]) == set(tilt_bench.PHASE_NAMES.values())


def test_start_errors_only_change_the_initial_bias_variance(tmp_path):
    _tiny_run(tmp_path, "kf1d", {"rho": 0.4, "q00": 7e-9, "q11": 7e-12})
    r = tilt_bench.start_errors(tmp_path, p0_bias=1e-4, head_s=4.0)
    assert 0.0 < r["p0_0_head_share"] <= 1.0 and 0.0 < r["p0_bias_head_share"] <= 1.0
    same = tilt_bench.start_errors(tmp_path, p0_bias=0.0, head_s=4.0)
    assert same["p0_bias"] == same["p0_0"]
