"""The FAEKF paper's claim (Odry et al. 2020, Sensors 20, 803, Table 2) with the project's engine.

On short ``bench6dof`` recordings with vibration, external acceleration and magnetic perturbation,
PSO tunes the EKF (q_q, q_w, rho of eq. 36) and the fuzzy-adaptive EKF (the same plus K2..K7 of
Table 1; K1 = 1) with the same budget and seed; the tuned FAEKF must score better than the tuned EKF on the
training recordings and on held-out ones. Table 2 reports the FAEKF ahead on all three measurements
(M1-M3; the eq.-35 product of its MSEs is 3-50x smaller than the EKF's), so the test asserts a
margin, not just a win. Fitness: eq. 35 with ``normalize: true`` (the geometric mean of the
per-axis MSEs), so train (3 recordings) and test (2 recordings) are on the same scale.

Also checked here: the bench starts from rest (the filters initialise from an undisturbed sample).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import yaml

from objectives.attitude.data.synthetic import PHASES, bench6dof
from tuner.config import config_from_dict
from tuner.run import run

pytestmark = pytest.mark.slow  # every test here tunes, sweeps or drives a browser

DURATION_S = 20.0
TRAIN_SEEDS = (1, 2, 3)
TEST_SEEDS = (101, 102)
BUDGET = {"method": "pso", "population": 12, "generations": 10}


def _spec(seed: int) -> dict:
    return {"synthetic": {"generator": "bench6dof", "duration_s": DURATION_S, "rate_hz": 1000, "seed": seed}}


def _tune(flt: str, tmp_path: Path) -> dict:
    raw = {
        "name": f"claim-{flt}",
        "seed": 7,
        "objective": {
            "kind": "filter", "filter": flt,
            "data": {"train": [_spec(s) for s in TRAIN_SEEDS], "test": [_spec(s) for s in TEST_SEEDS]},
            "metric": "euler_mse_geomean", "metric_options": {"normalize": True},
            "warmup_s": 2.0, "report": {"traces": False},
        },
        "optimizer": dict(BUDGET),
        "parallel": {"backend": "serial", "n_jobs": 1},
    }
    res = run(config_from_dict(raw, base_dir=Path(".")), run_dir=tmp_path / flt, quiet=True, report=False)
    assert res.status == "finished" and res.n_evals == BUDGET["population"] * BUDGET["generations"]
    return yaml.safe_load((tmp_path / flt / "best.yaml").read_text())


def _mean_rmse(split: dict) -> np.ndarray:
    """(3,) roll, pitch, yaw RMSE (deg), mean over the recordings of a split."""
    return np.mean([[m["roll_rmse_deg"], m["pitch_rmse_deg"], m["yaw_rmse_deg"]] for m in split.values()], axis=0)


@pytest.fixture(scope="module")
def tuned(tmp_path_factory) -> dict:
    tmp = tmp_path_factory.mktemp("faekf_claim")
    return {flt: _tune(flt, tmp) for flt in ("ekf", "faekf")}


def test_tuned_faekf_beats_tuned_ekf_on_train_and_held_out(tuned):
    ekf, fa = tuned["ekf"]["evaluation"], tuned["faekf"]["evaluation"]
    for split in ("train", "test"):
        f_ekf, f_fa = ekf[f"{split}_fitness"], fa[f"{split}_fitness"]
        assert np.isfinite(f_fa) and np.isfinite(f_ekf)
        # eq. 35 (normalised) is a mean square: 0.8 means ~10 % lower RMSE (measured: 0.39 on
        # train, 0.60 on test with this budget and seed)
        assert f_fa < 0.8 * f_ekf, (split, f_fa, f_ekf)
        # and the attitude is really better, not only the product of the MSEs
        r_ekf, r_fa = _mean_rmse(ekf[split]), _mean_rmse(fa[split])
        assert r_fa.mean() < r_ekf.mean(), (split, r_fa, r_ekf)
    # the held-out errors stay in the range of Table 2 (a few degrees), no recording lost
    assert _mean_rmse(fa["test"]).max() < 6.0, fa["test"]
    for m in fa["test"].values():
        assert m["total_rmse_deg"] < 10.0, fa["test"]


def test_tuned_faekf_raises_r_under_disturbance(tuned):
    """The adaptive part is used: the tuned singletons grow R for the most disturbed rules."""
    p = tuned["faekf"]["params"]
    k = np.array([p[f"K{i + 1}"] for i in range(7)])
    assert np.all(k >= 1.0)                      # Table 1 only raises R (K_BOUNDS)
    assert k[3:].max() > 20.0 * k[0], k          # a big disturbance => R grows by > 20x


def test_bench_starts_at_rest():
    rec = bench6dof(duration_s=12.0, seed=102)   # seed 102 used to start inside a disturbed phase
    n0 = int(2.5 / rec.dt)                       # 3 s static, ramps are centred on the 3 s mark
    assert np.all(rec.extra["phase"][: int(3.0 / rec.dt)] == PHASES.index(PHASES[0]))
    np.testing.assert_allclose(rec.extra["true_ext_acc"][:n0], 0.0, atol=0.0)
    np.testing.assert_allclose(rec.extra["mag_disturbance"][:n0], 0.0, atol=0.0)
    np.testing.assert_allclose(rec.extra["true_gyr"][:n0], 0.0, atol=1e-12)
    # start_static_s=0 restores a start in a random phase (seed 102: not static)
    assert bench6dof(duration_s=12.0, seed=102, start_static_s=0.0).extra["phase"][0] != 0
    with pytest.raises(ValueError, match="start_static_s"):
        bench6dof(duration_s=12.0, seed=1, start_static_s=-1.0)
