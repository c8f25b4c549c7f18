"""The filter objective: metrics agree with the reference metric functions, splits, failures, evaluate."""

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import yaml

from objectives.attitude import metrics as M
from objectives.attitude.data.synthetic import synthetic
from objectives.attitude.filters import get_filter
from objectives.attitude.fused_errors import error_sums
from objectives.attitude.objective import FilterObjective
from tests.conftest import run_tuner
from tuner.config import config_from_dict
from tuner.run import run

BENCH = {"synthetic": {"generator": "bench6dof", "duration_s": 8, "seed": 1}}
BENCH2 = {"synthetic": {"generator": "bench6dof", "duration_s": 8, "seed": 2}}
TILT = {"synthetic": {"generator": "tilt1d", "duration_s": 8, "seed": 1}}


def test_fused_error_pass_matches_reference_metrics():
    rec = synthetic("bench6dof", duration_s=8, seed=3)
    q = get_filter("madgwick")(beta=0.05).run(rec)
    q[1000:1010] = np.nan  # a few diverged samples count as pi errors in both
    mask = rec.motion.copy()
    mask[:500] = False
    s = error_sums(q, rec.quat, mask)
    st, be = M.euler_stats(q, rec.quat, mask), M.broad_errors(q, rec.quat, mask)
    assert np.allclose(s.rmse_deg, st.rmse_deg, rtol=1e-12)
    assert np.allclose(s.broad_rmse_deg, [be.total_rmse_deg, be.heading_rmse_deg, be.inclination_rmse_deg],
                       rtol=1e-12)
    assert s.n == st.n_samples and s.n_nonfinite == 10


@pytest.mark.parametrize("metric", ["euler_mse_geomean", "broad_mean_rmse", "broad_total_rmse", "euler_rmse_mean"])
def test_objective_metrics_equal_reference_functions(metric):
    obj = FilterObjective("mahony", [BENCH, BENCH2], metric=metric)
    params = {"Kp": 0.8, "Ki": 0.01}
    got = obj(params).fitness
    recs = obj.recordings()
    flt = get_filter("mahony")(**params)
    qs = [flt.run(r) for r in recs]
    if metric == "euler_mse_geomean":
        ref = M.euler_mse_geomean([(q, r.quat, r.motion) for q, r in zip(qs, recs)])
    elif metric == "broad_mean_rmse":
        ref = np.mean([M.broad_errors(q, r.quat, r.motion).total_rmse_deg for q, r in zip(qs, recs)])
    elif metric == "broad_total_rmse":
        tot = np.concatenate([M.broad_error_angles(q, r.quat)[0] for q, r in zip(qs, recs)])
        ref = np.degrees(np.sqrt(np.mean(tot**2)))
    else:
        ref = np.mean([np.mean(M.euler_stats(q, r.quat).rmse_deg) for q, r in zip(qs, recs)])
    assert got == pytest.approx(ref, rel=1e-10)


def test_mse_1d_on_tilt_bench_uses_true_angle():
    obj = FilterObjective("kf1d", [TILT], metric="mse_1d")
    ev = obj({})
    rec = obj.recordings()[0]
    res = get_filter("kf1d")().run_detailed(rec)
    assert ev.fitness == pytest.approx(M.mse_1d(res.diagnostics["angle"], rec.extra["angle"], rec.motion))


def test_diverging_filter_is_a_failed_evaluation(monkeypatch):
    obj = FilterObjective("madgwick", [BENCH])
    cls = obj._cls
    orig = cls._run

    def broken(self, rec, q0):
        res = orig(self, rec, q0)
        res.quat[50:] = np.nan
        return res

    monkeypatch.setattr(cls, "_run", broken)
    ev = obj({"beta": 0.1})
    assert ev.status == "failed" and "diverged on bench6dof-1" in ev.error


def test_recordings_are_not_pickled_and_load_once():
    import pickle

    obj = FilterObjective("madgwick", [BENCH])
    obj({"beta": 0.1})
    assert obj._data.train is not None and obj.prepare("train").recordings == obj.recordings("train")
    blob = pickle.dumps(obj)
    assert len(blob) < 5000, "loaded recordings must not travel with the objective"
    twin = pickle.loads(blob)
    assert twin({"beta": 0.1}).fitness == obj({"beta": 0.1}).fitness


def test_config_errors_name_the_key(tmp_path):
    base = {"kind": "filter", "filter": "madgwick", "data": [BENCH]}
    with pytest.raises(ValueError, match="objective.metric: unknown metric 'rmse'"):
        FilterObjective.from_config({**base, "metric": "rmse"}, tmp_path)
    with pytest.raises(ValueError, match="objective.fixed.gamma: not a parameter of madgwick"):
        FilterObjective.from_config({**base, "fixed": {"gamma": 1}}, tmp_path)
    with pytest.raises(ValueError, match="objective.filter: unknown filter 'kalman'"):
        FilterObjective.from_config({**base, "filter": "kalman"}, tmp_path)
    with pytest.raises(ValueError, match=r"csv.path: file not found"):
        FilterObjective.from_config({**base, "data": [{"csv": {"path": "nope.csv"}}]}, tmp_path)
    with pytest.raises(ValueError, match="kfold"):
        FilterObjective.from_config({**base, "data": {"all": [BENCH, BENCH2], "kfold": {"k": 3, "fold": 0}}},
                                    tmp_path)


def test_kfold_split_holds_out_every_kth_recording(tmp_path):
    specs = [{"synthetic": {"generator": "bench6dof", "duration_s": 3, "seed": s}} for s in range(4)]
    obj = FilterObjective.from_config({"kind": "filter", "filter": "madgwick",
                                       "data": {"all": specs, "kfold": {"k": 2, "fold": 1}}}, tmp_path)
    assert [r.name for r in obj.recordings("train")] == ["bench6dof-0", "bench6dof-2"]
    assert [r.name for r in obj.recordings("test")] == ["bench6dof-1", "bench6dof-3"]


def test_score_keeps_the_outputs_of_the_first_recordings_only_when_limited(tmp_path):
    # the run report draws one recording: it keeps that one's estimates, not all of them, with the same scores
    specs = [{"synthetic": {"generator": "bench6dof", "duration_s": 3, "seed": s}} for s in range(3)]
    obj = FilterObjective.from_config({"kind": "filter", "filter": "madgwick", "data": specs}, tmp_path)
    full = obj.score({"beta": 0.1}, keep_outputs=True)
    one = obj.score({"beta": 0.1}, keep_outputs=True, outputs_limit=1)
    none = obj.score({"beta": 0.1}, keep_outputs=True, outputs_limit=0)
    assert list(full.outputs) == ["bench6dof-0", "bench6dof-1", "bench6dof-2"]
    assert list(one.outputs) == ["bench6dof-0"] and not none.outputs
    np.testing.assert_array_equal(one.outputs["bench6dof-0"].quat, full.outputs["bench6dof-0"].quat)
    assert one.fitness == none.fitness == full.fitness and one.recordings == full.recordings


def test_run_metadata_reads_versions_without_importing_the_packages():
    # importing pandas and cma only for their versions cost about 100 MB of resident memory in every run
    code = ("import sys, tuner.run as r; v = r._versions(); "
            "print(all(v[m] for m in ('numpy', 'pandas', 'cma', 'yaml')), "
            "'pandas' in sys.modules, 'cma' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.split()
    assert out == ["True", "False", "False"]


def _tiny_kf_job(tmp_path):
    return {"name": "kf", "seed": 4,
            "objective": {"kind": "filter", "filter": "kf1d", "metric": "mse_1d",
                          "data": {"train": [{"synthetic": {"generator": "tilt1d", "duration_s": 10, "seed": 1}}],
                                   "test": [{"synthetic": {"generator": "tilt1d", "duration_s": 10, "seed": 2}}]}},
            "optimizer": {"method": "pso", "population": 8, "generations": 5}, "parallel": {"backend": "serial"},
            "output": str(tmp_path)}


@pytest.mark.slow
def test_tiny_pso_run_improves_thesis_initial_kf_parameters(tmp_path):
    """Thesis 3.1.3.1: PSO improves on the initial parameters (8 x 5 PSO, short tilt1d recording)."""
    cfg = config_from_dict(_tiny_kf_job(tmp_path), base_dir=tmp_path)
    res = run(cfg, run_dir=tmp_path / "kf", quiet=True, report=False)  # scores.csv and figures/euler_*: the objective's
    from objectives.attitude.filters.kf1d import KF1D

    obj = FilterObjective("kf1d", [{"synthetic": {"generator": "tilt1d", "duration_s": 10, "seed": 1}}],
                          metric="mse_1d")
    initial = obj({k: KF1D.defaults[k] for k in ("rho", "q00", "q11")}).fitness
    assert res.best_fitness < initial
    best = yaml.safe_load((res.run_dir / "best.yaml").read_text())
    ev = best["evaluation"]
    assert ev["train_fitness"] == pytest.approx(res.best_fitness)
    assert ev["test_fitness"] > 0 and "tilt1d-2" in ev["test"]
    assert (res.run_dir / "scores.csv").exists()
    assert any(p.name.startswith("euler_") for p in (res.run_dir / "figures").iterdir())


@pytest.mark.slow
def test_tuner_evaluate_json_on_other_data(tmp_path):
    cfg = config_from_dict(_tiny_kf_job(tmp_path), base_dir=tmp_path)
    res = run(cfg, run_dir=tmp_path / "kf", quiet=True)
    data = tmp_path / "other.yaml"
    data.write_text(yaml.safe_dump({"data": [{"synthetic": {"generator": "tilt1d", "duration_s": 5, "seed": 9}}]}))
    out = run_tuner("evaluate", res.run_dir, "--data", data, "--json")
    assert out.returncode == 0, out.stderr
    doc = json.loads(out.stdout)
    assert set(doc["recordings"]) == {"tilt1d-9"} and doc["fitness"] > 0
    obj = FilterObjective("kf1d", [{"synthetic": {"generator": "tilt1d", "duration_s": 5, "seed": 9}}],
                          metric="mse_1d")
    assert doc["fitness"] == pytest.approx(obj(res.best_params).fitness, rel=1e-12)
    same = run_tuner("evaluate", res.run_dir, "--json")
    assert json.loads(same.stdout)["fitness"] == pytest.approx(res.best_fitness, rel=1e-12)
    assert Path(res.run_dir / "report.html").exists()


def test_split_is_checked_and_recordings_are_substituted_explicitly():
    obj = FilterObjective("madgwick", [BENCH])
    with pytest.raises(ValueError, match="train, test"):
        obj.score({"beta": 0.1}, "validation")
    with pytest.raises(ValueError, match="train, test"):
        obj.recordings("tests")
    rec = obj.recordings("train")[0]
    other = FilterObjective("madgwick", []).with_recordings(train=[rec])
    assert other.recordings("train") == (rec,) and other.recordings("test") == ()
    assert other({"beta": 0.1}).fitness == obj({"beta": 0.1}).fitness
    assert obj._data.test is None, "a split loads on first use only"


def test_prepare_computes_the_fixed_disturbance_inputs_once_and_stays_out_of_pickles():
    import pickle

    obj = FilterObjective("faekf", [BENCH])
    prepared = obj.prepare("train")
    assert obj.prepare("train") is prepared and len(prepared.dist) == 1
    (per,) = prepared.dist.values()
    assert all(d is not None for d in per)
    first = obj(obj.default_params())
    assert len(prepared.dist) == 1 and next(iter(prepared.dist.values()))[0] is per[0], "reused, not recomputed"
    twin = pickle.loads(pickle.dumps(obj))
    assert twin._prepared == {} and twin._data.train is None
    assert twin(obj.default_params()).fitness == first.fitness


def test_fold_objective_describes_and_deploys(tmp_path):
    """A cross-validation fold's objective (and the held-out selection's parts, built the same way) has
    recordings given as a ``("subset", specs, names)`` spec: its provenance and deployment name the data
    and the recordings it keeps. ``describe`` read that spec as k-fold and raised ``IndexError`` after every
    run with ``validation.select`` (configs/broad_realtime.yaml)."""
    specs = [{"synthetic": {"generator": "bench6dof", "duration_s": 3, "seed": s}} for s in range(3)]
    obj = FilterObjective.from_config({"kind": "filter", "filter": "madgwick", "data": specs}, tmp_path)
    name, tune_on, held = obj.cv_folds(3)[0]
    for side in (tune_on, held):
        desc = side.describe()
        assert desc["data"]["all"] == specs
        assert set(desc["data"]["subset"]) == {r.name for r in side.recordings("train")}
        dep = side.deployment(side.default_params())
        assert dep is not None
