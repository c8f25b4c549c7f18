"""Population kernel of the closed-loop objective (backend: threads): results identical to the serial path."""

import csv
import os
import pathlib
import signal
import subprocess
import sys
import time

import numpy as np
import pytest
import yaml

from objectives.control.design import evaluate_loop, failed_design
from objectives.control.objective import ClosedLoopObjective
from tuner.config import config_from_dict
from tuner.objective import Evaluation
from tuner.run import run

CONFIGS = pathlib.Path(__file__).parents[2] / "configs"
REPO = CONFIGS.parent


def _doc(name, duration_s=2.0):
    doc = yaml.safe_load((CONFIGS / name).read_text())
    doc["objective"]["duration_s"] = duration_s
    return doc


def _candidates(doc, n, seed=0):
    from tuner.space import Space

    space = Space.from_dict(doc["parameters"])
    return space.decode_batch(np.random.default_rng(seed).random((n, space.dim)))


@pytest.mark.parametrize("cfg", ["wmp_pid.yaml", "wmp_lqr.yaml", "wmp_fuzzy_protective.yaml"])
@pytest.mark.slow
def test_batch_equals_serial_bit_for_bit(cfg):
    doc = _doc(cfg)
    obj = ClosedLoopObjective.from_config(doc["objective"], CONFIGS)
    params = _candidates(doc, 9)
    ref = [obj(p) for p in params]
    got = obj.evaluate_batch(params, 2)
    assert all(isinstance(g, Evaluation) for g in got)
    assert got == ref  # fitness, status, error and every metric
    assert {r.status for r in ref} <= {"ok", "failed"}
    assert obj.evaluate_batch(params[:2], 1) == ref[:2]


@pytest.mark.slow
def test_fallen_and_undesignable_candidates_fail_as_in_serial():
    doc = _doc("wmp_lqr.yaml")
    obj = ClosedLoopObjective.from_config(doc["objective"], CONFIGS)
    good = _candidates(doc, 1)[0]
    params = [good, {**good, "r_u1": -1.0}, {**good, "q_theta3": 1e-9, "q_nu": 1e5}]
    ref = [obj(p) for p in params]
    got = obj.evaluate_batch(params, 2)
    assert got == ref
    assert ref[1].status == "failed" and ref[1].error.startswith("controller design failed")
    assert ref[2].status == "failed" and "fell" in ref[2].error and ref[2].metrics["status_code"] == 1.0


@pytest.mark.slow
def test_a_report_scores_an_undesignable_candidate_as_the_run_does():
    """The reports' score of the start and the tuned values (``design.evaluate_loop``) is the objective's
    evaluation, a controller that cannot be designed (a negative input weight) included."""
    doc = _doc("wmp_lqr.yaml")
    obj = ClosedLoopObjective.from_config(doc["objective"], CONFIGS)
    good = _candidates(doc, 1)[0]
    bad = {**good, "r_u1": -1.0}
    assert evaluate_loop(obj.loop, good) == obj(good)
    with pytest.raises(ValueError) as why:
        obj.loop.evaluate(bad)
    assert evaluate_loop(obj.loop, bad) == obj(bad) == failed_design(why.value)
    assert obj(bad).status == "failed" and obj(bad).error == f"controller design failed: {why.value}"


def _history(rd):
    with open(rd / "history.csv") as fh:
        return [{k: v for k, v in row.items() if k != "seconds"} for row in csv.DictReader(fh)]


@pytest.mark.slow
def test_history_of_a_pendulum_run_is_identical_serial_and_threads(tmp_path):
    doc = _doc("wmp_pid.yaml")
    rows = {}
    for backend in ("serial", "threads"):
        raw = {**doc, "name": backend, "optimizer": {"method": "pso", "population": 8, "generations": 2},
               "parallel": {"backend": backend, "n_jobs": 2}, "output": str(tmp_path / "runs")}
        run(config_from_dict(raw, source=str(CONFIGS / "wmp_pid.yaml"), base_dir=CONFIGS),
            run_dir=tmp_path / backend, quiet=True, report=False)
        rows[backend] = _history(tmp_path / backend)
    assert len(rows["serial"]) == 16 and rows["threads"] == rows["serial"]


@pytest.mark.slow
def test_ctrl_c_interrupts_a_threads_run(tmp_path):
    doc = _doc("wmp_lqr.yaml", duration_s=8.0)
    doc.update(name="ctrl-c", optimizer={"method": "pso", "population": 8, "generations": 500},
               parallel={"backend": "threads", "n_jobs": 2}, output=str(tmp_path / "runs"))
    doc["objective"]["profile"] = "thesis_2s"
    p = tmp_path / "job.yaml"
    p.write_text(yaml.safe_dump(doc))
    env = {**os.environ, "PYTHONPATH": str(REPO)}
    proc = subprocess.Popen([sys.executable, "-m", "tuner", "run", str(p)], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, cwd=REPO, env=env)
    deadline = time.time() + 240
    hist = None
    while time.time() < deadline:
        found = list((tmp_path / "runs").glob("*/history.csv"))
        if found and found[0].stat().st_size > 0 and len(found[0].read_text().splitlines()) > 1:
            hist = found[0]
            break
        time.sleep(0.2)
    assert hist is not None, "the run wrote no history"
    proc.send_signal(signal.SIGINT)
    stdout, stderr = proc.communicate(timeout=120)
    assert proc.returncode == 1, stderr
    assert "status: interrupted" in stdout and "tuner resume" in stderr
