"""Small jobs for the run and run-directory tests, the pieces of a run killed and resumed from the CLI, and
unrendered figures for the tests that read none."""

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
import yaml

from tuner.config import config_from_dict


def unrendered_figures(mp) -> None:
    """Through the monkeypatch ``mp``, every figure a run draws (its report's, its objective's) is saved as an
    empty file and not laid out: rendering the PNGs (and ``tight_layout``, which renders the text to measure
    it) is most of a brief run's time, and a test that reads no figure needs the file only to exist. The
    figures are still built, from the same data."""
    from matplotlib.figure import Figure

    def savefig(self, fname, *args, **kwargs):
        if hasattr(fname, "write"):  # an open file: tuner.figures writes through a temporary one
            return
        Path(fname).write_bytes(b"")

    mp.setattr(Figure, "savefig", savefig)
    mp.setattr(Figure, "tight_layout", lambda self, *args, **kwargs: None)


@pytest.fixture(scope="module")
def unrendered():
    """For a module whose tests read no figure (``pytestmark = pytest.mark.usefixtures("unrendered")``, the
    fixture imported): :func:`unrendered_figures` for the whole module."""
    with pytest.MonkeyPatch.context() as mp:
        unrendered_figures(mp)
        yield


def sphere_job(tmp_path, name: str = "h", **over) -> dict:
    """A raw config dict of a tiny serial PSO on the 2-d sphere (12 evaluations), writing below ``tmp_path``;
    ``over`` replaces top-level keys."""
    raw = {"name": name, "seed": 2, "output": str(tmp_path / "runs"),
           "objective": {"kind": "function", "function": "sphere", "dim": 2},
           "optimizer": {"method": "pso", "population": 4, "generations": 3}, "parallel": {"backend": "serial"}}
    raw.update(over)
    return raw



def failing_python_job(tmp_path, module: str, error: str, name: str = "h") -> Path:
    """``job.yaml`` of a :func:`sphere_job` on the Python objective ``module:f`` over ``x`` in [0, 1], which
    scores 1.0 at x = 0.5 and raises ``error`` (a Python expression) everywhere else; the module is written
    beside the job."""
    (tmp_path / f"{module}.py").write_text("def f(params):\n    if params['x'] == 0.5:\n        return 1.0\n"
                                          f"    raise {error}\n")
    job = tmp_path / "job.yaml"
    job.write_text(yaml.safe_dump(sphere_job(tmp_path, name, objective={"kind": "python", "callable": f"{module}:f"},
                                             parameters={"x": {"low": 0.0, "high": 1.0}})))
    return job

def rastrigin_job(tmp_path, dim: int, population: int, generations: int, **over):
    """The config of a serial PSO run on ``dim``-D Rastrigin; ``over`` updates top-level sections."""
    raw = {"name": "t", "seed": 3,
           "objective": {"kind": "function", "function": "rastrigin", "dim": dim},
           "optimizer": {"method": "pso", "population": population, "generations": generations},
           "parallel": {"backend": "serial"}, "output": str(tmp_path / "runs")}
    for k, v in over.items():
        raw[k] = {**raw.get(k, {}), **v} if isinstance(v, dict) else v
    return config_from_dict(raw, source=str(tmp_path / "job.yaml"), base_dir=tmp_path)


def write_function_job(tmp_path, name: str, seed: int, objective: dict, optimizer: dict) -> Path:
    """Write ``<tmp_path>/<name>.yaml``: a serial run of a test-function objective; returns its path."""
    cfg = {"name": name, "seed": seed, "objective": {"kind": "function", **objective}, "optimizer": optimizer,
           "parallel": {"backend": "serial"}, "output": str(tmp_path / "runs")}
    p = tmp_path / f"{name}.yaml"
    p.write_text(yaml.safe_dump(cfg))
    return p


def load_job(path, tmp_path):
    """The config of a job file written by :func:`write_function_job`."""
    return config_from_dict(yaml.safe_load(Path(path).read_text()), base_dir=tmp_path)


def start_cli_run(job_file, run_dir, report: bool = True, **popen) -> subprocess.Popen:
    """``python -m tuner run <job_file> --run-dir <run_dir> -q`` in a child process (output discarded
    unless ``popen`` says otherwise); ``report=False`` adds ``--no-report``."""
    kw = {"stdout": subprocess.DEVNULL, "stderr": subprocess.DEVNULL, **popen}
    return subprocess.Popen([sys.executable, "-m", "tuner", "run", str(job_file), "--run-dir", str(run_dir), "-q",
                             *([] if report else ["--no-report"])], **kw)


def kill_after_generations(proc: subprocess.Popen, run_dir, generations: int, timeout_s: float = 60.0) -> None:
    """SIGKILL ``proc`` once the checkpoint of ``run_dir`` counts ``generations`` (or after ``timeout_s``)."""
    ck = Path(run_dir) / "checkpoint.json"
    deadline = time.time() + timeout_s
    while time.time() < deadline:
        try:
            if json.loads(ck.read_text())["generations"] >= generations:
                break
        except (OSError, ValueError, KeyError):  # not written yet, or caught mid-replace
            pass
        time.sleep(0.02)
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait()


def resume_cli(run_dir, *args: str) -> subprocess.CompletedProcess:
    """``tuner resume <run_dir> [args]`` to completion (in this process), output captured."""
    from tests.conftest import run_tuner

    return run_tuner("resume", run_dir, *args)
