"""Peers leave nothing in the working directory (pyswarms writes report.log on import and per optimiser)."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import pytest

from benchmarks.common import peer, scratch_cwd


def test_peer_import_writes_no_file_into_the_working_directory(tmp_path, monkeypatch):
    lib = tmp_path / "lib"
    lib.mkdir()
    (lib / "noisy_peer_lib.py").write_text("open('report.log', 'w').write('log')\nVALUE = 3\n")
    work = tmp_path / "work"
    work.mkdir()
    monkeypatch.chdir(work)
    monkeypatch.syspath_prepend(str(lib))
    monkeypatch.delitem(sys.modules, "noisy_peer_lib", raising=False)
    mod = peer("noisy_peer_lib")
    assert mod is not None and mod.VALUE == 3
    assert list(work.iterdir()) == [] and Path.cwd() == work
    assert peer("no_such_peer_library_here") is None and Path.cwd() == work


def test_scratch_cwd_returns_even_after_an_error(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    with pytest.raises(RuntimeError), scratch_cwd():
        assert Path.cwd() != tmp_path
        Path("report.log").write_text("x")
        raise RuntimeError("boom")
    assert Path.cwd() == tmp_path and list(tmp_path.iterdir()) == []


def test_a_pyswarms_run_writes_no_file_into_the_working_directory(tmp_path, monkeypatch):
    if importlib.util.find_spec("pyswarms") is None:  # importorskip would import it here, writing report.log
        pytest.skip("pyswarms is not installed")
    from benchmarks.optimizers import run_method

    monkeypatch.chdir(tmp_path)
    out = run_method("pyswarms_gbest", lambda u: float(((u - 0.3) ** 2).sum()), 2, 12, 4, 0)
    assert out["error"] == "" and out["n_evals"] == 12
    assert list(tmp_path.iterdir()) == [] and Path.cwd() == tmp_path
