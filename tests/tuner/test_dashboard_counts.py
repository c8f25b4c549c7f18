"""The dashboard's header counts runs and sweeps in plain words (singular for one)."""

from __future__ import annotations

import tuner
from tuner.dashboard import write_dashboard

JOB = {"name": "dash-rosen", "seed": 1, "objective": {"kind": "function", "function": "rosenbrock", "dim": 2},
       "optimizer": {"method": "pso", "population": 4, "generations": 2}, "parallel": {"backend": "serial"}}


def test_header_counts_in_words(tmp_path):
    root = tmp_path / "runs"
    root.mkdir()
    assert "0 runs and 0 sweeps under this folder" in write_dashboard(root).read_text()
    tuner.tune(dict(JOB), run_dir=root / "one", progress=False)
    text = write_dashboard(root).read_text()
    assert "1 run and 0 sweeps under this folder" in text and "1 runs" not in text
    tuner.tune(dict(JOB), run_dir=root / "two", progress=False)
    assert "2 runs and 0 sweeps under this folder" in write_dashboard(root).read_text()
