"""Runs end to end: reproducibility across backends, kill and resume, failures recorded, refinement."""

import json
import signal
import subprocess
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import yaml

from tests.tuner.jobs import (
    kill_after_generations,
    load_job,
    rastrigin_job,
    resume_cli,
    start_cli_run,
    write_function_job,
)
from tuner.objective import PENALTY
from tuner.run import resume, run
from tuner.rundir import RunError


def job(tmp_path, **over):
    return rastrigin_job(tmp_path, 4, 8, 6, **over)


def history(run_dir):
    return pd.read_csv(Path(run_dir) / "history.csv", keep_default_na=False)


@pytest.mark.parametrize("method", ["pso", "cmaes", "de", "random"])
@pytest.mark.slow
def test_loky_history_equals_serial(tmp_path, method):
    """Same config and seed: identical history.csv serially and on 2 loky workers.

    The ``seconds`` column (wall time of each evaluation) is the only one allowed to differ.
    """
    a = run(job(tmp_path, optimizer={"method": method}), run_dir=tmp_path / "a", quiet=True, report=False)
    b = run(job(tmp_path, optimizer={"method": method}, parallel={"backend": "loky", "n_jobs": 2}),
            run_dir=tmp_path / "b", quiet=True, report=False)
    ha, hb = history(a.run_dir).drop(columns="seconds"), history(b.run_dir).drop(columns="seconds")
    pd.testing.assert_frame_equal(ha, hb)
    assert a.best_params == b.best_params and a.best_fitness == b.best_fitness
    assert len(ha) == a.n_evals


def test_failures_are_recorded_and_run_goes_on(tmp_path):
    res = run(job(tmp_path, objective={"fail_every": 5, "nan_every": 7}, optimizer={"generations": 5}),
              run_dir=tmp_path / "f", quiet=True, report=False)
    h = history(res.run_dir)
    failed = h[h["status"] == "failed"]
    assert res.status == "finished" and len(h) == 40
    assert len(failed) > 0
    assert failed["error"].str.contains("RuntimeError: synthetic failure").any()
    assert failed["error"].str.contains("non-finite fitness nan").any()
    assert (failed["fitness"] == PENALTY).all()
    ok = h[h["status"] == "ok"]
    assert res.best_fitness == ok["fitness"].min()
    best_row = ok.loc[ok["fitness"].idxmin()]
    assert all(best_row[k] == pytest.approx(v) for k, v in res.best_params.items())
    meta = yaml.safe_load((res.run_dir / "meta.json").read_text())
    assert meta["n_failed"] == len(failed)


def test_run_directory_contents(tmp_path):
    res = run(job(tmp_path), quiet=True)
    d = res.run_dir
    assert d.parent == tmp_path / "runs" and d.name.split("-")[1] == "t"
    for f in ("config.yaml", "meta.json", "history.csv", "best.yaml", "checkpoint.json", "report.md",
              "figures/convergence.png"):
        assert (d / f).exists(), f
    cfg = yaml.safe_load((d / "config.yaml").read_text())
    assert cfg["parameters"]["x0"] == {"low": -5.12, "high": 5.12}
    assert cfg["parallel"] == {"backend": "serial", "n_jobs": 2, "address": None}
    best = yaml.safe_load((d / "best.yaml").read_text())
    assert best["fitness"] == res.best_fitness and set(best["params"]) == {"x0", "x1", "x2", "x3"}
    # the result holds that best point; its best_* views derive from it
    assert res.best.params == best["params"] == res.best_params and res.best.metrics == res.best_metrics
    assert (best["found"]["stage"], best["found"]["generation"], best["found"]["eval"]) == \
        (res.best.stage, res.best.generation, res.best.eval)
    with pytest.raises(RunError, match="exists and is not empty; use `tuner resume "):
        run(job(tmp_path), run_dir=d, quiet=True)


def test_run_without_report_writes_the_same_records(tmp_path):
    """``report=False`` leaves out report.md and its figures, nothing else: same history and best."""
    a = run(job(tmp_path), run_dir=tmp_path / "a", quiet=True)
    b = run(job(tmp_path), run_dir=tmp_path / "b", quiet=True, report=False)
    assert (a.run_dir / "report.md").exists() and not (b.run_dir / "report.md").exists()
    assert not (b.run_dir / "figures" / "convergence.png").exists()
    pd.testing.assert_frame_equal(history(a.run_dir).drop(columns="seconds"),
                                  history(b.run_dir).drop(columns="seconds"))
    assert (b.run_dir / "best.yaml").exists() and a.best_params == b.best_params and b.status == "finished"


@pytest.mark.slow
def test_without_report_no_live_view_is_written_and_resume_writes_none_either(tmp_path, monkeypatch):
    """``report=False`` also leaves out the live view (here due after every generation), in ``run`` and in
    ``resume``; records are those of the same run and resume with their report."""
    import tuner.report

    monkeypatch.setattr(tuner.report, "LIVE_MIN_INTERVAL_S", 0.0)

    def stop_after_two(g):
        if g.generation == 1:
            raise KeyboardInterrupt

    runs = {}
    for name, report in (("with", True), ("without", False)):
        cut = run(job(tmp_path), run_dir=tmp_path / name, quiet=True, on_generation=stop_after_two, report=report)
        assert cut.status == "interrupted"
        assert (cut.run_dir / "report.html").exists() is report  # an interrupted run's page is its live view
        runs[name] = resume(cut.run_dir, quiet=True, report=report)
        assert runs[name].status == "finished"
        assert {p.name for p in cut.run_dir.iterdir()} >= {"history.csv", "best.yaml", "meta.json"}
        for f in ("report.md", "report.html", "figures"):
            assert (cut.run_dir / f).exists() is report, f
    pd.testing.assert_frame_equal(history(tmp_path / "with").drop(columns="seconds"),
                                  history(tmp_path / "without").drop(columns="seconds"))
    assert runs["with"].best_params == runs["without"].best_params


def test_run_leaves_global_rng_alone(tmp_path):
    state = np.random.get_state()[1].copy()
    run(job(tmp_path, optimizer={"method": "cmaes"}), run_dir=tmp_path / "g", quiet=True)
    assert np.array_equal(np.random.get_state()[1], state)


def test_refinement_stages_narrow_bounds(tmp_path):
    res = run(job(tmp_path, optimizer={"generations": 4, "refine": {"stages": 2, "shrink": 0.2}}),
              run_dir=tmp_path / "r", quiet=True, report=False)
    h = history(res.run_dir)
    assert sorted(h["stage"].unique()) == [0, 1] and len(h) == 64
    s1 = h[h["stage"] == 1]
    width = s1[["x0", "x1", "x2", "x3"]].max() - s1[["x0", "x1", "x2", "x3"]].min()
    assert (width <= 0.2 * 10.24 + 1e-9).all()
    assert res.best_fitness <= h[h["stage"] == 0]["fitness"].min()


def _write_job(tmp_path, name, **objective):
    return write_function_job(tmp_path, name, 11, {"function": "rosenbrock", "dim": 3, **objective},
                              {"method": "de", "population": 6, "generations": 12})


@pytest.mark.slow
def test_sigkill_then_resume_matches_uninterrupted(tmp_path):
    ref = run(load_job(_write_job(tmp_path, "ref"), tmp_path), run_dir=tmp_path / "ref", quiet=True, report=False)
    run_dir = tmp_path / "killed"
    proc = start_cli_run(_write_job(tmp_path, "killed", sleep_s=0.02), run_dir, report=False)
    kill_after_generations(proc, run_dir, 3)
    ck = run_dir / "checkpoint.json"
    done = json.loads(ck.read_text())["n_evals"]
    assert 0 < done < 72, "the run must have been killed part-way"
    meta = yaml.safe_load((run_dir / "meta.json").read_text())
    assert meta["status"] == "running"  # killed: no chance to say otherwise
    out = resume_cli(run_dir, "-q", "--no-report")
    assert out.returncode == 0, out.stderr
    res = yaml.safe_load((run_dir / "best.yaml").read_text())
    assert res["params"] == ref.best_params and res["fitness"] == ref.best_fitness
    h_ref, h_res = history(ref.run_dir).drop(columns="seconds"), history(run_dir).drop(columns="seconds")
    pd.testing.assert_frame_equal(h_ref, h_res)


@pytest.mark.slow
def test_interrupt_sets_status_and_resume_refuses_finished(tmp_path):
    job_file = _write_job(tmp_path, "int", sleep_s=0.1)
    run_dir = tmp_path / "int"
    proc = start_cli_run(job_file, run_dir, report=False, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    ck = run_dir / "checkpoint.json"
    deadline = time.time() + 60
    while not ck.exists() and time.time() < deadline:
        time.sleep(0.02)
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 1, (err, (run_dir / "meta.json").read_text())
    assert yaml.safe_load((run_dir / "meta.json").read_text())["status"] == "interrupted"
    res = resume(run_dir, quiet=True, report=False)
    assert res.status == "finished" and res.n_evals == 72
    out = resume_cli(run_dir)
    assert out.returncode == 2 and "already finished" in out.stderr
