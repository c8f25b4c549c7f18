"""Fault injection without strace: kill the run at its k-th write, for every k, then resume.

The hook is ``TUNER_FAULT_KILL_AT_WRITE`` in :mod:`tuner.rundir` (``os._exit(137)`` just before the
k-th write takes effect, or with ``k:after`` just after it). A short job (sphere, PSO, 3 generations,
2 refinement stages, serial) is killed at every write it makes, the last included; each time the
killed directory must never show a best that the history contradicts, and after resuming (or
re-running a directory killed before it started) ``history.csv`` and ``best.yaml`` must equal those
of the uninterrupted run.
"""

import json
import os
import shutil
import tempfile
from pathlib import Path

import pandas as pd
import pytest
import yaml

import tuner.rundir as rundir
from tuner.config import config_from_dict
from tuner.run import resume, run


def _cfg(tmp_path):
    raw = {"name": "f", "seed": 5, "objective": {"kind": "function", "function": "sphere", "dim": 2},
           "optimizer": {"method": "pso", "population": 4, "generations": 3, "refine": {"stages": 2, "shrink": 0.3}},
           "parallel": {"backend": "serial"}, "output": str(tmp_path / "runs")}
    return config_from_dict(raw, source=str(tmp_path / "f.yaml"), base_dir=tmp_path)


def _in_child(fn, env: dict[str, str]) -> int:
    """Run ``fn`` in a forked child with ``env`` set; return its exit code."""
    pid = os.fork()
    if pid == 0:  # pragma: no cover - child
        code = 0
        try:
            os.environ.update(env)
            rundir._n_writes = 0
            fn()
        except BaseException:
            code = 1
        os._exit(code)
    _, status = os.waitpid(pid, 0)
    return os.waitstatus_to_exitcode(status)


def _best(d: Path) -> dict:
    doc = yaml.safe_load((d / "best.yaml").read_text())
    doc.pop("run")
    return doc


def _history(d: Path) -> pd.DataFrame:
    return pd.read_csv(d / "history.csv", keep_default_na=False).drop(columns="seconds")


def _check_killed_dir(d: Path) -> None:
    """What `tuner show` / `tuner export` would read right after the kill is not stale."""
    ck = d / "checkpoint.json"
    if not ck.exists():
        return
    n = json.loads(ck.read_text())["n_evals"]
    rows = pd.read_csv(d / "history.csv", keep_default_na=False, nrows=n)
    committed = rows[rows["status"] == "ok"]["fitness"].min()
    best = yaml.safe_load((d / "best.yaml").read_text())
    assert best["fitness"] <= committed, "best.yaml is behind the checkpointed history"
    row = pd.read_csv(d / "history.csv", keep_default_na=False, nrows=best["found"]["eval"] + 1).iloc[-1]
    assert row["fitness"] == best["fitness"] and all(row[k] == v for k, v in best["params"].items())


@pytest.fixture
def fast_dir(tmp_path):
    """A directory on tmpfs when there is one: the run fsyncs every write, which a loaded disk makes slow."""
    shm = Path("/dev/shm")
    if not (shm.is_dir() and os.access(shm, os.W_OK)):
        yield tmp_path
        return
    d = Path(tempfile.mkdtemp(prefix="tuner-faults-", dir=shm))
    try:
        yield d
    finally:
        shutil.rmtree(d, ignore_errors=True)


@pytest.mark.slow
def test_kill_at_every_write_then_resume_equals_uninterrupted(fast_dir):
    tmp_path = fast_dir
    # no report: report.md and its figures are not part of what is compared (nor written through the run
    # directory's writes counted here), and plotting would dominate the time
    cfg = _cfg(tmp_path)

    def start(d):
        return run(cfg, run_dir=d, quiet=True, report=False)

    before = rundir._n_writes
    ref = start(tmp_path / "ref")
    n_writes = rundir._n_writes - before
    assert ref.status == "finished" and ref.n_evals == 24 and n_writes > 20
    h_ref, b_ref = _history(ref.run_dir), _best(ref.run_dir)
    for k in range(1, n_writes + 1):
        for when in ("before", "after"):
            d = tmp_path / f"k{k}{when}"
            code = _in_child(lambda d=d: start(d), {rundir.FAULT_ENV: f"{k}:{when}"})
            assert code == 137, f"write {k} ({when}) was not reached"
            _check_killed_dir(d)
            if (d / "meta.json").exists() or (d / "config.yaml").exists():
                status = json.loads((d / "meta.json").read_text())["status"] if (d / "meta.json").exists() else ""
                if status == "finished":  # killed after its last write: nothing left to resume
                    with pytest.raises(rundir.RunError, match=r": already finished$"):
                        resume(d, quiet=True, report=False)
                else:
                    code = _in_child(lambda d=d: resume(d, quiet=True, report=False), {})
                    assert code == 0, f"resume after write {k} {when}"
            else:  # killed before config.yaml existed: the directory is reused by a new run
                assert _in_child(lambda d=d: start(d), {}) == 0
            pd.testing.assert_frame_equal(_history(d), h_ref, obj=f"history after kill at write {k} {when}")
            assert _best(d) == b_ref, f"best.yaml after kill at write {k} {when}"
            assert json.loads((d / "meta.json").read_text())["status"] == "finished"
            assert not list(d.glob(".*.tmp*")), f"temporary files left after kill at write {k} {when}"
