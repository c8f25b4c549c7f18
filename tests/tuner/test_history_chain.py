"""The digest chain of history.csv (history.chain): any edited row, the last checkpointed generation's included,
is refused by resume, show and report with the row named; histories of older versions stay readable."""

from __future__ import annotations

import pandas as pd
import pytest

from tests.conftest import run_tuner
from tuner.config import config_from_dict
from tuner.digest import row_digest
from tuner.run import resume, run
from tuner.rundir import RunError


def _cfg(tmp_path, backend="serial", generations=4):
    raw = {"name": "chain", "seed": 5, "output": str(tmp_path / "runs"),
           "objective": {"kind": "function", "function": "rosenbrock", "dim": 2},
           "optimizer": {"method": "pso", "population": 5, "generations": generations},
           "parallel": {"backend": backend, "n_jobs": 2}}
    return config_from_dict(raw, base_dir=tmp_path)


def _interrupted(tmp_path, name="r"):
    """A run stopped (as by Ctrl-C) after 3 of its 4 generations, without its report."""
    seen = []

    def progress(msg):
        if msg.startswith("gen "):
            seen.append(msg)
            if len(seen) == 3:
                raise KeyboardInterrupt

    res = run(_cfg(tmp_path), run_dir=tmp_path / name, progress=progress, report=False)
    assert res.status == "interrupted"
    return res.run_dir


def tuner(*args):
    return run_tuner(*args)


def _edit(d, row, col, value):
    h = pd.read_csv(d / "history.csv", keep_default_na=False, dtype=str)
    h.loc[row, col] = value
    h.to_csv(d / "history.csv", index=False)


@pytest.mark.parametrize("col, value", [("fitness", "1e-09"), ("status", "failed"), ("error", "x")])
def test_an_edit_in_the_last_checkpointed_generation_is_refused_everywhere(tmp_path, col, value):
    d = _interrupted(tmp_path)
    _edit(d, 14, col, value)  # rows 10-14: the last generation the checkpoint covers
    with pytest.raises(RunError, match=r"history.csv: row eval=14: does not match its digest"):
        resume(d, quiet=True)
    for cmd in ("show", "report"):
        out = tuner(cmd, d)
        assert out.returncode == 2 and out.stderr.startswith("error: ") and "row eval=14" in out.stderr, out.stderr
        assert len(out.stderr.strip().splitlines()) == 1


def test_removed_or_swapped_rows_are_refused(tmp_path):
    d = _interrupted(tmp_path)
    h = pd.read_csv(d / "history.csv", keep_default_na=False, dtype=str)
    h.iloc[[0, 1, 2, 3, 4, 6, 5, 7, 8, 9, 10, 11, 12, 13, 14]].to_csv(d / "history.csv", index=False)
    with pytest.raises(RunError, match=r"row eval=6"):
        resume(d, quiet=True)


def test_the_chain_is_the_same_for_serial_and_parallel_rows_and_ignores_seconds(tmp_path):
    row = {"eval": 0, "x0": "0.5", "fitness": "1.0", "status": "ok", "error": "", "seconds": "0.1"}
    assert row_digest("h", row) == row_digest("h", {**row, "seconds": "9.9"}) != row_digest("h2", row)
    assert row_digest("h", row) != row_digest("h", {**row, "fitness": "1.0000001"})
    a = run(_cfg(tmp_path), run_dir=tmp_path / "a", quiet=True, report=False)
    b = run(_cfg(tmp_path, backend="loky"), run_dir=tmp_path / "b", quiet=True, report=False)
    ha = pd.read_csv(a.run_dir / "history.csv").drop(columns="seconds")
    pd.testing.assert_frame_equal(ha, pd.read_csv(b.run_dir / "history.csv").drop(columns="seconds"))
    assert tuner("show", a.run_dir).returncode == 0


def test_resumed_history_continues_the_chain_and_a_history_without_its_chain_is_refused(tmp_path, monkeypatch):
    monkeypatch.delenv("TUNER_CHAIN_KEY", raising=False)
    monkeypatch.setenv("XDG_CONFIG_HOME", str(tmp_path / "no-config"))  # no chain key of the user's
    d = _interrupted(tmp_path)
    assert resume(d, quiet=True, report=False).status == "finished"
    out = tuner("show", d)
    assert out.returncode == 0 and "note:" not in out.stdout, out.stderr
    (d / "history.chain").unlink()  # the chain removed beside an edited history: nothing vouches for it
    for cmd in ("show", "report"):
        out = tuner(cmd, d)
        assert out.returncode == 2 and "history.chain: missing beside history.csv" in out.stderr, out.stderr
