"""The engine with ``cmaes_restart`` (population changing between restarts) and ``auto``: progress names
the chosen method, and a killed run resumed by replay equals the uninterrupted one."""

import pandas as pd
import pytest

from tests.tuner.jobs import kill_after_generations, load_job, resume_cli, start_cli_run, write_function_job
from tuner.run import run

OPT = {"method": "cmaes_restart", "generations": 40, "cma_options": {"tolx": 0.02}}


def _write_job(tmp_path, name, optimizer, **objective):
    return write_function_job(tmp_path, name, 5, {"function": "rastrigin", "dim": 2, **objective}, optimizer)


@pytest.mark.slow
def test_auto_prints_its_choice(tmp_path):
    lines = []
    res = run(load_job(_write_job(tmp_path, "a", {"method": "auto", "generations": 10}), tmp_path),
              run_dir=tmp_path / "a", progress=lines.append, report=False)
    assert res.status == "finished" and res.n_evals >= 200
    assert "optimizer: auto -> cmaes" in lines  # 20 x 10 = 200 evaluations in 2-D: 100 per dimension


@pytest.mark.slow
def test_restarts_survive_kill_and_resume(tmp_path):
    ref = run(load_job(_write_job(tmp_path, "ref", OPT), tmp_path), run_dir=tmp_path / "ref", quiet=True,
              report=False)
    h_ref = pd.read_csv(ref.run_dir / "history.csv", keep_default_na=False).drop(columns="seconds")
    assert h_ref["generation"].value_counts().nunique() > 1, "the reference must restart with a larger population"
    run_dir = tmp_path / "killed"
    proc = start_cli_run(_write_job(tmp_path, "killed", OPT, sleep_s=0.01), run_dir, report=False)
    kill_after_generations(proc, run_dir, 25)
    out = resume_cli(run_dir, "-q", "--no-report")
    assert out.returncode == 0, out.stderr
    h_res = pd.read_csv(run_dir / "history.csv", keep_default_na=False).drop(columns="seconds")
    pd.testing.assert_frame_equal(h_ref, h_res)
