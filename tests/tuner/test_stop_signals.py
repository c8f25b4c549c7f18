"""SIGTERM and SIGHUP stop tuner as Ctrl-C does: in a run, a resume, a sweep (serial and with --jobs), the CV
after a run and the threads backend. The generation in progress is never recorded as failed evaluations, the
run ends `interrupted` with exit 1, and resuming gives the uninterrupted history."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pandas as pd
import pytest
import yaml

from tests.tuner.jobs import load_job, resume_cli, start_cli_run, write_function_job
from tests.tuner.kinds import kind_fixture
from tuner.config import config_from_dict
from tuner.run import resume, run
from tuner.space import Real, Space


def _history(run_dir) -> pd.DataFrame:
    return pd.read_csv(Path(run_dir) / "history.csv", keep_default_na=False).drop(columns="seconds")


def _job(tmp_path, name, sleep_s=0.05):
    return write_function_job(tmp_path, name, 11, {"function": "rosenbrock", "dim": 3, "sleep_s": sleep_s},
                              {"method": "de", "population": 6, "generations": 10})


def _wait_for(path: Path, timeout_s: float = 60.0) -> None:
    deadline = time.time() + timeout_s
    while not path.exists() and time.time() < deadline:
        time.sleep(0.02)
    assert path.exists(), f"{path} never appeared"


def _status(run_dir) -> str:
    return json.loads((Path(run_dir) / "meta.json").read_text())["status"]


@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGHUP])
@pytest.mark.slow
def test_run_and_resume_stop_on_the_signal_and_resume_to_the_uninterrupted_history(tmp_path, sig):
    ref = run(load_job(_job(tmp_path, "ref", 0.0), tmp_path), run_dir=tmp_path / "ref", quiet=True, report=False)
    run_dir = tmp_path / "sig"
    proc = start_cli_run(_job(tmp_path, "sig"), run_dir, report=False, stdout=subprocess.PIPE,
                         stderr=subprocess.PIPE, text=True)
    _wait_for(run_dir / "checkpoint.json")
    proc.send_signal(sig)
    out, err = proc.communicate(timeout=60)
    assert proc.returncode == 1, err
    assert "status: interrupted" in out and "Traceback" not in err
    assert _status(run_dir) == "interrupted"
    h = _history(run_dir)
    assert (h["status"] == "ok").all(), "the generation in progress was recorded as failures"
    assert 0 < len(h) < 60 and len(h) % 6 == 0

    # the resume is stopped by the same signal, then continued to the end
    proc = subprocess.Popen([sys.executable, "-m", "tuner", "resume", str(run_dir), "-q", "--no-report"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    n0 = len(h)
    deadline = time.time() + 60
    while len(_history(run_dir)) <= n0 + 6 and time.time() < deadline:
        time.sleep(0.05)
    proc.send_signal(sig)
    out, err = proc.communicate(timeout=60)
    assert proc.returncode == 1 and "status: interrupted" in out, err
    assert (_history(run_dir)["status"] == "ok").all()
    done = resume_cli(run_dir, "-q", "--no-report")
    assert done.returncode == 0, done.stderr
    pd.testing.assert_frame_equal(_history(ref.run_dir), _history(run_dir))
    assert yaml.safe_load((run_dir / "best.yaml").read_text())["fitness"] == ref.best_fitness


def _sweep_file(tmp_path, seeds) -> Path:
    base = _job(tmp_path, "base", 0.05)
    p = tmp_path / "sw.yaml"
    p.write_text(yaml.safe_dump({"sweep": {"name": "sw", "base": base.name, "seeds": seeds}}))
    return p


def _session_processes(sid: int) -> list[int]:
    pids = []
    for d in Path("/proc").iterdir():
        if d.name.isdigit():
            try:
                fields = (d / "stat").read_text().rsplit(")", 1)[1].split()
            except OSError:
                continue
            if int(fields[3]) == sid and fields[0] != "Z":
                pids.append(int(d.name))
    return pids


@pytest.mark.parametrize("jobs", [1, 2])
@pytest.mark.slow
def test_sweep_stops_on_sigterm_and_leaves_no_process_behind(tmp_path, jobs):
    sweep = _sweep_file(tmp_path, [1, 2, 3, 4])
    out_dir = tmp_path / "sweepdir"
    proc = subprocess.Popen([sys.executable, "-m", "tuner", "sweep", str(sweep), "--dir", str(out_dir), "-q",
                             "--jobs", str(jobs)], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            start_new_session=True)
    _wait_for(out_dir / "jobs" / "seed-1" / "checkpoint.json")
    proc.send_signal(signal.SIGTERM)
    t0 = time.time()
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 1, err
    assert "interrupted" in err and "Traceback" not in err
    assert time.time() - t0 < 20
    deadline = time.time() + 10
    while _session_processes(proc.pid) and time.time() < deadline:
        time.sleep(0.1)
    assert _session_processes(proc.pid) == [], "sweep workers left running"
    started = [d for d in (out_dir / "jobs").iterdir() if (d / "meta.json").exists()]
    assert len(started) < 4, "the sweep went on with its next jobs"
    for d in started:
        if (d / "history.csv").exists():
            assert (_history(d)["status"] == "ok").all()
    if jobs == 1:
        assert _status(out_dir / "jobs" / "seed-1") == "interrupted"


class _BatchSignals:
    """Quadratic objective whose ``evaluate_batch`` hook receives a SIGTERM at its second call."""

    takes_seed = False
    calls = 0

    def __init__(self, **options):
        pass

    @classmethod
    def from_config(cls, section, base_dir):
        return cls()

    def default_space(self):
        return Space([Real("a", -1.0, 1.0), Real("b", -1.0, 1.0)])

    def __call__(self, params):
        return (params["a"] - 0.3) ** 2 + (params["b"] + 0.1) ** 2

    def evaluate_batch(self, params_list, n_threads):
        type(self).calls += 1
        if type(self).calls == 2:
            os.kill(os.getpid(), signal.SIGTERM)
            time.sleep(0.5)  # the handler runs here, as when a kernel returns
        return [self(p) for p in params_list]


batch_kind = kind_fixture("batch_kind", "batch_signals_test", _BatchSignals)


def test_threads_backend_stops_on_sigterm_without_serial_rerun(tmp_path, batch_kind, capfd):
    raw = {"name": "thr", "seed": 1, "objective": {"kind": batch_kind}, "output": str(tmp_path),
           "optimizer": {"method": "pso", "population": 4, "generations": 5},
           "parallel": {"backend": "threads", "n_jobs": 2}}
    res = run(config_from_dict(raw, base_dir=tmp_path), run_dir=tmp_path / "thr", quiet=True, report=False)
    assert res.status == "interrupted"
    assert "evaluated serially" not in capfd.readouterr().err
    h = _history(tmp_path / "thr")
    assert len(h) == 4 and (h["status"] == "ok").all()


def test_sigterm_during_the_cv_after_a_run_marks_it_interrupted_and_resume_finishes_it(tmp_path):
    specs = [{"synthetic": {"generator": "bench6dof", "duration_s": 4, "seed": s}} for s in (1, 2, 3, 4)]
    raw = {"name": "cvsig", "seed": 3, "output": str(tmp_path / "runs"),
           "objective": {"kind": "filter", "filter": "madgwick", "metric": "broad_mean_rmse", "data": specs},
           "optimizer": {"method": "pso", "population": 4, "generations": 2}, "parallel": {"backend": "serial"},
           "validation": {"cv": "kfold", "folds": 2, "budget_fraction": 0.5}}

    def progress(msg):
        if msg.startswith("validation:"):
            os.kill(os.getpid(), signal.SIGTERM)

    res = run(config_from_dict(raw, base_dir=tmp_path), run_dir=tmp_path / "cv", progress=progress, report=False)
    assert res.status == "interrupted" and _status(tmp_path / "cv") == "interrupted"
    assert not (tmp_path / "cv" / "validation.json").exists()
    res = resume(tmp_path / "cv", quiet=True, report=False)
    assert res.status == "finished" and "cv" in json.loads((tmp_path / "cv" / "validation.json").read_text())
