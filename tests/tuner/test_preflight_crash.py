"""The default-parameter check of the preflight runs in a child process for `kind: python` objectives and for
the loky and Dask backends: an objective that ends the process there is one error line naming how."""

from __future__ import annotations

import os
import subprocess
import sys

import pytest
import yaml

from tests.conftest import run_tuner


@pytest.mark.parametrize("body, how", [
    ("os._exit(3)", "exited with status 3"),
    ("os.kill(os.getpid(), signal.SIGSEGV)", "killed by signal SIGSEGV"),
])
def test_a_crash_at_the_defaults_is_one_error_line(tmp_path, body, how):
    (tmp_path / "crashmod_u.py").write_text(f"import os, signal\ndef f(params):\n    {body}\n")
    job = tmp_path / "job.yaml"
    job.write_text(yaml.safe_dump({
        "name": "crash", "objective": {"kind": "python", "callable": "crashmod_u:f"},
        "parameters": {"x": {"low": 0.0, "high": 1.0}}, "optimizer": {"method": "random", "population": 4,
                                                                      "generations": 2},
        "parallel": {"backend": "serial"}, "output": str(tmp_path / "runs")}))
    out = subprocess.run([sys.executable, "-m", "tuner", "run", str(job)], capture_output=True, text=True,
                         timeout=120, env={**os.environ, "PYTHONPATH": str(tmp_path)})
    assert out.returncode == 2, (out.returncode, out.stderr)
    errors = [ln for ln in out.stderr.splitlines() if ln.startswith("error:")]
    assert len(errors) == 1 and how in errors[0] and "default parameters" in errors[0], out.stderr
    assert not (tmp_path / "runs").exists()


def test_an_impossible_validation_section_is_refused_before_tuning(tmp_path):
    job = tmp_path / "job.yaml"
    job.write_text(yaml.safe_dump({
        "name": "nocv", "objective": {"kind": "function", "function": "sphere", "dim": 2},
        "optimizer": {"method": "random", "population": 4, "generations": 2}, "parallel": {"backend": "serial"},
        "validation": {"cv": "kfold", "folds": 3}, "output": str(tmp_path / "runs")}))
    out = run_tuner("run", job)
    assert out.returncode == 2 and out.stderr.startswith(f"error: {job}: validation.cv: "), out.stderr
    assert "cannot be cross-validated" in out.stderr and not (tmp_path / "runs").exists()
