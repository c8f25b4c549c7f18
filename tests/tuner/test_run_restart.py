"""The engine with ``cmaes_restart`` (population changing between restarts) and ``auto``: progress names
the chosen method, and a killed run resumed by replay equals the uninterrupted one."""

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pandas as pd
import yaml

from tuner.config import config_from_dict
from tuner.run import run

OPT = {"method": "cmaes_restart", "generations": 40, "cma_options": {"tolx": 0.02}}


def _write_job(tmp_path, name, optimizer, **objective):
    cfg = {"name": name, "seed": 5, "objective": {"kind": "function", "function": "rastrigin", "dim": 2, **objective},
           "optimizer": optimizer, "parallel": {"backend": "serial"}, "output": str(tmp_path / "runs")}
    p = tmp_path / f"{name}.yaml"
    p.write_text(yaml.safe_dump(cfg))
    return p


def _load(p, tmp_path):
    return config_from_dict(yaml.safe_load(Path(p).read_text()), base_dir=tmp_path)


def test_auto_prints_its_choice(tmp_path):
    lines = []
    res = run(_load(_write_job(tmp_path, "a", {"method": "auto", "generations": 10}), tmp_path),
              run_dir=tmp_path / "a", progress=lines.append)
    assert res.status == "finished" and res.n_evals >= 200
    assert "optimizer: auto -> cmaes" in lines  # 20 x 10 = 200 evaluations in 2-D: 100 per dimension


def test_restarts_survive_kill_and_resume(tmp_path):
    ref = run(_load(_write_job(tmp_path, "ref", OPT), tmp_path), run_dir=tmp_path / "ref", quiet=True)
    h_ref = pd.read_csv(ref.run_dir / "history.csv", keep_default_na=False).drop(columns="seconds")
    assert h_ref["generation"].value_counts().nunique() > 1, "the reference must restart with a larger population"
    job_file = _write_job(tmp_path, "killed", OPT, sleep_s=0.01)
    run_dir = tmp_path / "killed"
    proc = subprocess.Popen([sys.executable, "-m", "tuner", "run", str(job_file), "--run-dir", str(run_dir), "-q"],
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    ck = run_dir / "checkpoint.json"
    deadline = time.time() + 60
    while time.time() < deadline:
        try:
            if json.loads(ck.read_text())["generations"] >= 25:
                break
        except Exception:
            pass
        time.sleep(0.02)
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait()
    out = subprocess.run([sys.executable, "-m", "tuner", "resume", str(run_dir), "-q"], capture_output=True,
                         text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    h_res = pd.read_csv(run_dir / "history.csv", keep_default_na=False).drop(columns="seconds")
    pd.testing.assert_frame_equal(h_ref, h_res)
