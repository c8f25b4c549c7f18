"""Population kernel of the filter objective (backend: threads): results identical to the serial path."""

import csv

import numpy as np
import pytest

from objectives.attitude.batch import batchable
from objectives.attitude.objective import FilterObjective
from tests.serial import serial_outcomes
from tuner.config import config_from_dict
from tuner.evaluate import Evaluator
from tuner.objective import Evaluation
from tuner.run import run

BENCH = {"synthetic": {"generator": "bench6dof", "duration_s": 4, "seed": 1}}
BENCH2 = {"synthetic": {"generator": "bench6dof", "duration_s": 3, "seed": 2}}
TILT = {"synthetic": {"generator": "tilt1d", "duration_s": 4, "seed": 1}}
TILT2 = {"synthetic": {"generator": "tilt1d", "duration_s": 3, "seed": 2}}
FAEKF_FIXED = {"window": 200, "fft_length": 256, "f_thr": 10.0, "omega_thr": 0.26}


def _candidates(obj, n, seed=0):
    rng = np.random.default_rng(seed)
    return obj.default_space().decode_batch(rng.random((n, obj.default_space().dim)))


def _same(batch, serial):
    assert len(batch) == len(serial)
    for b, s in zip(batch, serial):
        if isinstance(s, BaseException):
            assert type(b) is type(s) and str(b) == str(s)
        else:
            assert isinstance(b, Evaluation) and b == s  # fitness and every metric bit for bit


@pytest.mark.parametrize("flt, fixed, extra", [
    ("madgwick", {}, {}),
    ("madgwick", {"use_mag": False, "zeta": 0.01}, {"metric": "euler_rmse_mean"}),
    ("mahony", {}, {"metric": "broad_total_rmse", "warmup_s": 0.5}),
    ("madgwick", {"mag_rejection": True, "rest_bias": True, "acc_lp_tau_s": 3.0, "zeta": 0.01}, {}),
    ("mahony", {"mag_rejection": True, "mag_max_rejection_s": 1.0, "Ki": 0.02}, {"metric": "broad_total_rmse"}),
    ("ekf", {}, {"q0": "truth"}),
    ("faekf", FAEKF_FIXED, {"metric": "euler_rmse_mean", "metric_options": {"aggregate": "median"}}),
    ("kf1d", {}, {"metric": "mse_1d", "data": [TILT, TILT2]}),
    ("kf1d", {}, {"metric": "euler_rmse_mean", "data": [TILT]}),
    ("qukf", {}, {}),
    ("qraukf", {"n_sigma": 2.0}, {"metric": "broad_total_rmse", "q0": "truth"}),
])
@pytest.mark.slow
def test_batch_equals_serial_bit_for_bit(flt, fixed, extra):
    extra = dict(extra)
    obj = FilterObjective(flt, extra.pop("data", [BENCH, BENCH2]), fixed=dict(fixed), **extra)
    params = _candidates(obj, 7)
    assert batchable(obj)
    _same(obj.evaluate_batch(params, 2), serial_outcomes(obj, params))
    _same(obj.evaluate_batch(params[:3], 1), serial_outcomes(obj, params[:3]))


@pytest.mark.parametrize("flt, key", [("madgwick", "beta"), ("mahony", "Kp")])
@pytest.mark.slow
def test_candidates_with_and_without_robust_blocks_share_a_batch(flt, key):
    """Madgwick / Mahony pairs with the blocks on get the longer coefficients and state, the others zero padding
    (blocks off); every candidate still equals its serial evaluation."""
    obj = FilterObjective(flt, [BENCH, BENCH2])
    params = [{key: 0.3}, {key: 0.3, "mag_rejection": True}, {key: 0.2, "rest_bias": True, "acc_lp_tau_s": 2.0},
              {key: 0.3, "mag_rejection": "yes"}, {key: 0.5}]
    got = obj.evaluate_batch(params, 2)
    _same(got, serial_outcomes(obj, params))
    assert isinstance(got[3], ValueError) and "mag_rejection" in str(got[3])
    assert got[2].fitness != obj({key: 0.2}).fitness  # the blocks are on in that pair


def test_a_bad_candidate_fails_alone_with_the_serial_message():
    obj = FilterObjective("madgwick", [BENCH], prior={"strength": 1.0})
    params = [{"beta": 0.05}, {"beta": -1.0}, {"beta": 0.2}]
    got = obj.evaluate_batch(params, 2)
    ref = serial_outcomes(obj, params)
    assert isinstance(got[1], ValueError) and "beta" in str(got[1])
    _same(got, ref)
    assert got[0].metrics["prior_penalty"] >= 0


def test_an_empty_batch_prepares_and_returns_nothing():
    obj = FilterObjective("mahony", [BENCH])
    assert obj.evaluate_batch([], 2) == []


@pytest.mark.parametrize("flt, section", [("akf1d", {"data": [TILT], "metric": "mse_1d"}),
                                          ("madgwick", {"data": [TILT], "metric": "mse_1d"}),
                                          ("ekf", {"data": [BENCH], "fixed": {"mag_rejection": True}}),
                                          ("qraukf", {"data": [BENCH], "fixed": {"rest_bias": True}}),
                                          ("vqf", {"data": [BENCH]})])
def test_configurations_without_a_kernel_return_none(flt, section):
    obj = FilterObjective.from_config({"kind": "filter", "filter": flt, **section})
    assert not batchable(obj)
    assert obj.evaluate_batch([obj.default_params()], 2) is None


def test_the_kernel_is_declared_by_the_class_itself():
    """Every declared ``population`` is a :class:`Population` of the class's unit; a subclass (which may change
    ``_run``) is batched only under a declaration of its own."""
    from types import SimpleNamespace

    from objectives.attitude.batch import Population
    from objectives.attitude.filters import FILTERS, get_filter
    from objectives.attitude.filters.base import own
    from objectives.attitude.filters.mahony import Mahony

    declared = {n: own(get_filter(n), "population") for n in FILTERS}
    assert all(isinstance(p, Population) for p in declared.values() if p is not None)
    assert {n for n, p in declared.items() if p} == {"madgwick", "mahony", "ekf", "faekf", "kf1d", "qukf", "qraukf"}

    class Tuned(Mahony):
        def _run(self, rec, q0):  # pragma: no cover - never run
            raise AssertionError

    assert Tuned.population is Mahony.population  # inherited as an attribute, but not the subclass's own
    assert not batchable(SimpleNamespace(_cls=Tuned, metric="euler_rmse_mean"))


def test_importing_every_filter_leaves_numba_typed_lists_unloaded():
    """The typed-list templates, once loaded, make numba type every later kernel slower: the filter classes and
    their population kernels import them only when a batch runs."""
    import subprocess
    import sys

    code = ("import sys\nfrom objectives.attitude.filters import FILTERS, get_filter\n"
            "for n in FILTERS: get_filter(n).population\n"
            "import objectives.attitude.batch\nprint('numba.typed.typedlist' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"


def _history(rd):
    with open(rd / "history.csv") as fh:
        return [{k: v for k, v in row.items() if k != "seconds"} for row in csv.DictReader(fh)]


def _run(tmp_path, objective, backend, name, parameters=None):
    raw = {"name": name, "seed": 5, "objective": objective,
           "optimizer": {"method": "pso", "population": 6, "generations": 2},
           "parallel": {"backend": backend, "n_jobs": 2}, "output": str(tmp_path / "runs")}
    if parameters:
        raw["parameters"] = parameters
    run(config_from_dict(raw, source=str(tmp_path / f"{name}.yaml"), base_dir=tmp_path), run_dir=tmp_path / name,
        quiet=True, report=False)
    return _history(tmp_path / name)


@pytest.mark.slow
def test_history_of_a_filter_run_is_identical_serial_and_threads(tmp_path):
    objective = {"kind": "filter", "filter": "faekf", "data": [BENCH, BENCH2], "fixed": dict(FAEKF_FIXED),
                 "metric": "euler_mse_geomean", "warmup_s": 0.5}
    ref = _run(tmp_path, objective, "serial", "serial")
    got = _run(tmp_path, objective, "threads", "threads")
    assert len(ref) == 12 and got == ref


@pytest.mark.slow
def test_history_on_broad_is_identical_serial_and_threads(tmp_path, broad_dir):
    objective = {"kind": "filter", "filter": "madgwick", "metric": "broad_mean_rmse",
                 "data": [{"broad": {"dir": str(broad_dir), "trial": "07_undisturbed_fast_rotation_B",
                                     "stop_s": 35.0}}]}
    ref = _run(tmp_path, objective, "serial", "serial", {"beta": {"low": 0.001, "high": 1.0, "scale": "log"}})
    got = _run(tmp_path, objective, "threads", "threads", {"beta": {"low": 0.001, "high": 1.0, "scale": "log"}})
    assert got == ref and all(r["status"] == "ok" for r in got)


def test_threads_backend_uses_the_kernel_for_the_filter_objective():
    obj = FilterObjective("madgwick", [BENCH])
    params = _candidates(obj, 4, seed=3)
    with Evaluator(obj, "threads", n_jobs=2) as ev:
        recs = ev(params)
        assert ev.notes == []
    _same([r.evaluation for r in recs], serial_outcomes(obj, params))


@pytest.mark.slow
def test_with_a_timeout_the_batch_runs_in_a_forked_child_with_the_same_history(tmp_path):
    objective = {"kind": "filter", "filter": "mahony", "data": [BENCH]}
    ref = _run(tmp_path, objective, "serial", "serial")
    got = _run(tmp_path, {**objective, "timeout_s": 120.0}, "threads", "threads")
    assert got == ref


@pytest.mark.slow
def test_a_runaway_error_fails_in_the_batch_as_serially():
    # the EKF's candidates of the parametrised test above include one whose finite error runs away
    # (objectives.attitude.divergence); the population kernel must flag it too, not score it
    obj = FilterObjective("ekf", [BENCH, BENCH2], q0="truth")
    params = _candidates(obj, 7)
    ref = serial_outcomes(obj, params)
    runaway = [i for i, e in enumerate(ref) if isinstance(e, Evaluation) and "grows without bound" in e.error]
    assert runaway, "no runaway candidate: the check below would prove nothing"
    got = obj.evaluate_batch(params, 2)
    for i in runaway:
        assert got[i].status == "failed" and got[i].error == ref[i].error
