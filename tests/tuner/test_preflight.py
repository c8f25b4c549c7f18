"""Preflight: bad data, names and objectives stop `tuner run` before the first generation (exit 2)."""

import json
import subprocess
import sys

import numpy as np
import pytest
import yaml

from tests.conftest import run_tuner as tuner

COLUMNS = {"time": "t", "gyr": ["gx", "gy", "gz"], "acc": ["ax", "ay", "az"], "quat": ["qw", "qx", "qy", "qz"]}


def write_csv(path, n=300, rate_hz=100.0, gyr_scale=1.0, drop=None, nan_row=None):
    """A recording at rest with a slow wobble on gyr (rad/s unless scaled), truth = identity."""
    t = np.arange(n) / rate_hz
    gyr = np.stack([0.5 * np.sin(t), 0.3 * np.cos(t), 0.1 * np.sin(2 * t)], 1) * gyr_scale
    acc = np.tile([0.0, 0.0, 9.81], (n, 1))
    quat = np.tile([1.0, 0.0, 0.0, 0.0], (n, 1))
    cols = {"t": t, **{c: gyr[:, i] for i, c in enumerate(["gx", "gy", "gz"])},
            **{c: acc[:, i] for i, c in enumerate(["ax", "ay", "az"])},
            **{c: quat[:, i] for i, c in enumerate(["qw", "qx", "qy", "qz"])}}
    if drop:
        cols.pop(drop)
    rows = np.stack(list(cols.values()), 1)
    if nan_row is not None:
        rows[nan_row, 1] = np.nan
    path.write_text(",".join(cols) + "\n" + "\n".join(",".join(repr(float(v)) for v in r) for r in rows) + "\n")
    return path


def filter_job(tmp_path, csv="rec.csv", **over):
    cfg = {"name": "pf", "objective": {"kind": "filter", "filter": "madgwick", "metric": "euler_rmse_mean",
                                       "fixed": {"use_mag": False},
                                       "data": [{"csv": {"path": csv, "columns": COLUMNS}}]},
           "optimizer": {"method": "pso", "population": 4, "generations": 2}, "parallel": {"backend": "serial"},
           "output": str(tmp_path / "runs")}
    for k, v in over.items():
        if isinstance(v, dict) and isinstance(cfg.get(k), dict):
            cfg[k] = {**cfg[k], **v}
        else:
            cfg[k] = v
    p = tmp_path / "job.yaml"
    p.write_text(yaml.safe_dump(cfg))
    return p


def no_run_dir(tmp_path):
    return not (tmp_path / "runs").exists() or not any((tmp_path / "runs").iterdir())


@pytest.mark.parametrize("over, expected", [
    ({"parameters": {"betta": {"low": 0.01, "high": 1.0}}},
     ["parameters.betta", "not a parameter", "did you mean 'beta'", "allowed: acc_lp_tau_s, beta"]),
    ({"objective": {"fixed": {"betta": 0.1}}}, ["objective.fixed.betta", "not a parameter of madgwick", "beta"]),
    ({"objective": {"warmup_s": 5.0}}, ["objective.warmup_s", "5 s is not shorter than recording", "rec", "3 s"]),
    # a search range reaching outside what the filter accepts: every candidate there would fail
    ({"parameters": {"beta": {"low": -1.0, "high": 1.0}}},
     ["parameters.beta.low", "-1.0 is outside what the objective accepts", "beta must be in [0, inf)"]),
])
def test_bad_names_and_warmup_are_errors_before_any_evaluation(tmp_path, over, expected):
    write_csv(tmp_path / "rec.csv")
    out = tuner("run", str(filter_job(tmp_path, **over)))
    assert out.returncode == 2, out.stderr
    line = out.stderr.strip().splitlines()[-1]
    assert line.startswith(f"error: {tmp_path / 'job.yaml'}: ") and "Traceback" not in out.stderr
    for e in expected:
        assert e in line, (e, line)
    assert no_run_dir(tmp_path)


@pytest.mark.parametrize("kw, expected", [
    ({"drop": "gz"}, ["objective.data[0]", "gz"]),
    ({"nan_row": 17}, ["objective.data[0]", "rec.csv", "column 'gx'", "non-finite", "row 18"]),
])
def test_bad_recordings_are_errors_naming_the_data_entry(tmp_path, kw, expected):
    write_csv(tmp_path / "rec.csv", **kw)
    out = tuner("run", str(filter_job(tmp_path)))
    assert out.returncode == 2 and "Traceback" not in out.stderr, out.stderr
    line = out.stderr.strip().splitlines()[-1]
    for e in expected:
        assert e in line, (e, line)


@pytest.mark.slow
def test_gyro_in_deg_s_declared_rad_s_warns_and_runs(tmp_path):
    write_csv(tmp_path / "rec.csv", gyr_scale=180 / np.pi * 100)  # peaks ~ 2900 "rad/s"
    out = tuner("run", str(filter_job(tmp_path)), "--no-report")
    assert "warning: rec: gyr is declared rad/s" in out.stderr and "deg/s?" in out.stderr
    write_csv(tmp_path / "rec.csv", gyr_scale=0.1)  # 0.3 rad/s at the start would be a start in motion
    out = tuner("run", str(filter_job(tmp_path)), "--no-report")
    assert out.returncode == 0 and "warning" not in out.stderr, out.stderr


def test_unit_warnings_on_recordings():
    from objectives.attitude.data.recording import Recording
    from objectives.attitude.objective import unit_warnings

    n = 200
    gyr = np.tile([0.2, -0.1, 0.3], (n, 1))
    acc = np.tile([0.0, 0.0, 9.81], (n, 1))
    assert unit_warnings(Recording("ok", gyr, acc, None, 0.01)) == []
    (w,) = unit_warnings(Recording("dps", gyr * 200, acc, None, 0.01))
    assert "dps: gyr is declared rad/s" in w
    (w,) = unit_warnings(Recording("in_g", gyr, acc / 9.81, None, 0.01))
    assert "in_g: acc is declared m/s^2" in w and "in g?" in w


def python_job(tmp_path, body, **over):
    (tmp_path / "userobj.py").write_text(body)
    cfg = {"name": "py", "objective": {"kind": "python", "callable": "userobj:f"},
           "parameters": {"a": {"low": 0.0, "high": 1.0}},
           "optimizer": {"method": "pso", "population": 4, "generations": 2}, "parallel": {"backend": "serial"},
           "output": str(tmp_path / "runs"), **over}
    p = tmp_path / "job.yaml"
    p.write_text(yaml.safe_dump(cfg))
    return p


def test_objective_raising_at_the_defaults_is_an_error(tmp_path):
    p = python_job(tmp_path, "def f(p):\n    return 1.0 / p['b']\n")
    out = subprocess.run([sys.executable, "-m", "tuner", "run", str(p)], capture_output=True, text=True,
                         cwd=tmp_path, timeout=120, env={"PYTHONPATH": str(tmp_path), "PATH": "/usr/bin:/bin"})
    assert out.returncode == 2, out.stderr
    line = out.stderr.strip().splitlines()[-1]
    assert "objective: evaluating the default parameters failed: KeyError: 'b'" in line
    assert no_run_dir(tmp_path)


def test_run_where_every_evaluation_failed_exits_nonzero_and_says_why(tmp_path):
    p = python_job(tmp_path, "def f(p):\n    return float('nan')\n")
    out = subprocess.run([sys.executable, "-m", "tuner", "run", str(p), "--no-report"], capture_output=True, text=True,
                         cwd=tmp_path, timeout=120, env={"PYTHONPATH": str(tmp_path), "PATH": "/usr/bin:/bin"})
    assert out.returncode == 1, out.stderr
    assert "warning: the default parameters score as failed (non-finite fitness nan)" in out.stderr
    assert "every one of 8 evaluations failed; most common reasons: non-finite fitness nan (8 of 8 evaluations)" \
        in out.stderr


def closed_loop_job(tmp_path, controller, parameters):
    cfg = {"name": "cl", "objective": {"kind": "closed_loop", "controller": controller, "duration_s": 1.0},
           "parameters": parameters, "optimizer": {"population": 4, "generations": 1},
           "parallel": {"backend": "serial"}, "output": str(tmp_path / "runs")}
    p = tmp_path / "job.yaml"
    p.write_text(yaml.safe_dump(cfg))
    return p


def test_closed_loop_bound_outside_what_the_controller_accepts(tmp_path):
    out = tuner("run", str(closed_loop_job(tmp_path, "lqr", {"r_u1": {"low": 0.0, "high": 10.0}})))
    assert out.returncode == 2, out.stderr
    assert "parameters.r_u1.low: 0.0 is outside what the objective accepts" in out.stderr
    assert no_run_dir(tmp_path)


def test_closed_loop_misspelled_parameter(tmp_path):
    out = tuner("run", str(closed_loop_job(tmp_path, "pid", {"kp_1": {"low": 0.1, "high": 10.0}})))
    assert out.returncode == 2
    assert "parameters.kp_1: not a parameter of this objective (did you mean 'kp1'?)" in out.stderr


def test_dask_worker_check_reports_a_callable_missing_there(tmp_path):
    pytest.importorskip("distributed")
    from tuner.preflight import _worker_preflight
    from tuner.python_objective import PythonObjective

    assert _worker_preflight(PythonObjective("json:dumps")) == ""
    msg = _worker_preflight(PythonObjective("no_such_mod_q:f"))
    assert msg.startswith("ValueError: objective.callable: cannot import 'no_such_mod_q:f'")
    json.dumps(msg)


class _FailsOffMainThread:
    """Passes its preflight in the driver, fails where Dask runs it (a worker's thread)."""

    def __call__(self, params):
        return 0.0

    def preflight(self):
        import threading

        if threading.current_thread() is not threading.main_thread():
            raise ValueError("objective.callable: cannot import 'mymod:f' (No module named 'mymod')")
        return []


def test_preflight_runs_on_every_dask_worker(tmp_path):
    pytest.importorskip("distributed")
    from distributed import LocalCluster

    from tuner.config import ConfigError, config_from_dict
    from tuner.preflight import preflight
    from tuner.space import Real, Space

    with LocalCluster(n_workers=2, processes=False, dashboard_address=None) as cluster:
        cfg = config_from_dict({"objective": {"kind": "python", "callable": "m:f"},
                                "parameters": {"a": {"low": 0.0, "high": 1.0}},
                                "parallel": {"backend": "dask", "address": cluster.scheduler_address}},
                               source=str(tmp_path / "job.yaml"))
        with pytest.raises(ConfigError, match=r"objective: fails on Dask worker .* \(2 of 2 workers\): "
                                              r"ValueError: objective.callable: cannot import 'mymod:f'"):
            preflight(cfg, _FailsOffMainThread(), Space([Real("a", 0.0, 1.0)]), evaluate=False)


def test_a_bad_fixed_value_is_reported_as_such_not_as_a_bound(tmp_path):
    cfg = {"name": "fx", "output": str(tmp_path / "runs"),
           "objective": {"kind": "filter", "filter": "mahony", "fixed": {"mag_rejection": "maybe"},
                         "data": [{"synthetic": {"generator": "bench6dof", "duration_s": 2, "seed": 1}}]},
           "parameters": {"Kp": {"low": 0.1, "high": 2.0}}, "optimizer": {"population": 4, "generations": 1},
           "parallel": {"backend": "serial"}}
    p = tmp_path / "job.yaml"
    p.write_text(yaml.safe_dump(cfg))
    out = tuner("run", str(p))
    assert out.returncode == 2, out.stderr
    assert "objective: the objective refuses its parameters before any search: mahony: mag_rejection must be one of" \
        in out.stderr
    assert "parameters.Kp" not in out.stderr
    assert no_run_dir(tmp_path)
    cfg["objective"]["fixed"] = {}
    cfg["parameters"]["rest_bias"] = {"fixed": "sometimes"}
    p.write_text(yaml.safe_dump(cfg))
    out = tuner("run", str(p))
    assert out.returncode == 2 and "parameters.rest_bias.fixed: the objective refuses its parameters" in out.stderr
