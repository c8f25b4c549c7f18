"""A run or sweep directory someone hands over can make tuner neither run code nor touch other files: FIFOs,
hard links, oversized and deeply nested files are one error line (tuner.safe_io, tuner.records.load_json); a
history without its chain is refused and a keyed chain needs its key (tuner.digest); report scripts are kept
only by their content hash (tuner.assets); read-only commands never load the code a run names, and the code
commands load none from inside the run directory (tuner.trust)."""

from __future__ import annotations

import contextlib
import hashlib
import json
import os
import shutil
import signal
import sys
from pathlib import Path

import pytest
import yaml

from tests.conftest import one_error_line as one_error
from tests.conftest import run_tuner
from tests.tuner.jobs import failing_python_job, sphere_job
from tuner.config import config_from_dict
from tuner.records import config_hash
from tuner.run import run


@pytest.fixture
def handed(finished, tmp_path):
    d = tmp_path / "handed"
    shutil.copytree(finished, d, symlinks=True)
    return d


@contextlib.contextmanager
def no_hang(seconds=60):
    """A command that blocks (on a FIFO) fails the test instead of hanging the suite."""
    def expired(signum, frame):
        raise TimeoutError(f"blocked for {seconds} s")

    old = signal.signal(signal.SIGALRM, expired)
    signal.alarm(seconds)
    try:
        yield
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, old)


def _interrupted(d: Path) -> None:
    meta = json.loads((d / "meta.json").read_text())
    (d / "meta.json").write_text(json.dumps({**meta, "status": "interrupted"}))


# --- FIFOs, devices, hard links, sizes -------------------------------------------------------------
@pytest.mark.parametrize("entry", ["history.chain", "history.csv", "meta.json", "best.yaml", "config.yaml",
                                   "checkpoint.json", "figures/convergence.png"])
def test_a_fifo_in_a_run_directory_is_one_error_line_never_a_hang(handed, entry):
    (handed / entry).unlink()
    os.mkfifo(handed / entry)
    _interrupted(handed) if entry != "meta.json" else None
    cmds = {"history.chain": ["show", "report", "resume"], "history.csv": ["show", "report", "resume"],
            "meta.json": ["show", "report", "resume", "export"], "best.yaml": ["show", "report", "export"],
            "config.yaml": ["report", "resume", "export"], "checkpoint.json": ["show", "resume"],
            "figures/convergence.png": ["report"]}[entry]
    for cmd in cmds:
        with no_hang():
            out = run_tuner(cmd, handed)
        one_error(out, entry.split("/")[-1], "FIFO")


def test_a_hard_linked_lock_or_history_is_never_written(tmp_path, finished, handed):
    victim = tmp_path / "victim.txt"
    victim.write_text("the user's own file\n")
    job = tmp_path / "job.yaml"
    job.write_text(yaml.safe_dump(sphere_job(tmp_path, 'h')))
    empty = tmp_path / "empty"
    empty.mkdir()
    os.link(victim, empty / ".lock")  # `run --run-dir` truncated the victim to the pid
    one_error(run_tuner("run", job, "--run-dir", empty, "-q"), ".lock", "hard link")
    (handed / ".lock").unlink(missing_ok=True)
    os.link(victim, handed / ".lock")
    _interrupted(handed)
    one_error(run_tuner("resume", handed, "-q"), ".lock", "hard link")
    assert victim.read_text() == "the user's own file\n"

    other = tmp_path / "other"  # another run's history hard-linked in: resume appended 56 rows to it
    shutil.copytree(finished, other)
    before = (other / "history.csv").read_bytes()
    (handed / ".lock").unlink()
    (handed / "history.csv").unlink()
    os.link(other / "history.csv", handed / "history.csv")
    ck = json.loads((handed / "checkpoint.json").read_text())
    (handed / "checkpoint.json").write_text(json.dumps({**ck, "n_evals": 4}))  # a resume that would append
    one_error(run_tuner("resume", handed, "-q"), "history.csv", "hard link")
    assert (other / "history.csv").read_bytes() == before
    show = run_tuner("show", other)  # reading a hard-linked file is allowed (cp -al snapshots)
    assert show.returncode == 0, show.stderr


def test_an_oversized_file_is_refused_before_it_is_read(handed, monkeypatch):
    from tuner import safe_io

    limit = max(p.stat().st_size for p in handed.iterdir() if p.is_file())
    monkeypatch.setattr(safe_io, "MAX_READ_BYTES", limit)
    (handed / "meta.json").write_text(json.dumps({**json.loads((handed / "meta.json").read_text()),
                                                  "notes": ["x" * limit]}))
    one_error(run_tuner("show", handed), "meta.json", f"more than the {limit:,} tuner reads")


@pytest.mark.parametrize("depth", [100_000, 200])
def test_a_deeply_nested_meta_json_is_one_error_line(handed, tmp_path, depth):
    meta = json.loads((handed / "meta.json").read_text())
    text = json.dumps(meta)[:-1] + ', "extra": ' + "[" * depth + "]" * depth + "}"
    (handed / "meta.json").write_text(text)
    for cmd in (["show", handed], ["compare", handed, handed], ["export", handed], ["report", handed],
                ["resume", handed]):
        one_error(run_tuner(*cmd), "meta.json", "nested")
    listed = run_tuner("list", "runs", "--dir", tmp_path)
    assert listed.returncode == 0 and "unreadable" in listed.stdout and "nested" in listed.stdout, listed.stdout


# --- the history chain ----------------------------------------------------------------------------------------
def _edit_best_fitness(d: Path) -> None:
    import pandas as pd

    h = pd.read_csv(d / "history.csv", keep_default_na=False, dtype=str)
    h.loc[0, "fitness"] = "1e-30"
    h.to_csv(d / "history.csv", index=False)


def test_an_edited_history_without_its_chain_is_refused(handed):
    """An edited fitness plus a deleted history.chain resumed with best 1e-30."""
    _edit_best_fitness(handed)
    (handed / "history.chain").unlink()
    _interrupted(handed)
    for cmd in ("resume", "show", "report"):
        one_error(run_tuner(cmd, handed), "history.chain", "missing beside history.csv")


def _chain(d: Path, key: bytes | None) -> str:
    """history.chain recomputed over history.csv, as anyone can (key None) or a holder of ``key``."""
    import pandas as pd

    from tuner.digest import row_digest

    prev = json.loads((d / "meta.json").read_text())["config_hash"]
    head = (d / "history.chain").read_text().splitlines()[0] if key else ""
    lines = [head + "\n"] if head.startswith("#") else []
    for r in pd.read_csv(d / "history.csv", keep_default_na=False, dtype=str).to_dict("records"):
        prev = row_digest(prev, r, key)
        lines.append(f"{r['eval']},{prev}\n")
    return "".join(lines)


def test_a_keyed_chain_cannot_be_recomputed_without_the_key(tmp_path, monkeypatch):
    key = "k" * 32
    monkeypatch.setenv("TUNER_CHAIN_KEY", key)
    d = run(config_from_dict(sphere_job(tmp_path, 'h'), base_dir=tmp_path), run_dir=tmp_path / "keyed", quiet=True,
            report=False).run_dir
    head = (d / "history.chain").read_text().splitlines()[0]
    assert head.startswith("#hmac-sha256 key ") and key not in (d / "history.chain").read_text()
    assert run_tuner("show", d).returncode == 0
    _edit_best_fitness(d)
    good = (d / "history.chain").read_text()
    (d / "history.chain").write_text(_chain(d, b"not the key, but a guess"))  # forged without the key
    one_error(run_tuner("show", d), "row eval=0", "does not match")
    (d / "history.chain").write_text(good)
    one_error(run_tuner("show", d), "row eval=0", "does not match")
    (d / "history.chain").write_text(_chain(d, key.encode()))  # the key's holder can vouch for it
    assert run_tuner("show", d).returncode == 0
    monkeypatch.setenv("TUNER_CHAIN_KEY", "another key of 32 characters....")
    one_error(run_tuner("show", d), "keyed with the chain key", "not with the key set")
    monkeypatch.delenv("TUNER_CHAIN_KEY")
    monkeypatch.setenv("XDG_CONFIG_HOME", str(tmp_path / "cfg"))
    one_error(run_tuner("show", d), "keyed with the chain key", "no key is set")
    (tmp_path / "cfg" / "tuner").mkdir(parents=True)
    (tmp_path / "cfg" / "tuner" / "chain.key").write_text(key + "\n")  # the key file outside the run
    assert run_tuner("show", d).returncode == 0
    (d / "history.chain").write_text(_chain(d, None))  # downgraded to an unkeyed chain: read, with a note
    out = run_tuner("show", d)
    assert out.returncode == 0 and "note: history.chain is not keyed" in out.stdout, out.stdout


def test_a_short_chain_key_is_refused(tmp_path, monkeypatch):
    monkeypatch.setenv("TUNER_CHAIN_KEY", "short")
    job = tmp_path / "job.yaml"
    job.write_text(yaml.safe_dump(sphere_job(tmp_path, 'h')))
    one_error(run_tuner("run", job, "--run-dir", tmp_path / "r", "-q"), "TUNER_CHAIN_KEY", "shorter than 16")


# --- report scripts ------------------------------------------------------------------------------------
def _sha(p: Path) -> str:
    return hashlib.sha256(p.read_bytes()).hexdigest()


def test_a_planted_report_script_of_the_right_size_is_replaced(tmp_path, finished):
    pytest.importorskip("plotly")
    from tuner.interactive import _plotly_js

    src = _plotly_js()
    root = tmp_path / "runs"
    d = root / "handed"
    shutil.copytree(finished, d)
    evil = b"alert(1);//" + b" " * (src.stat().st_size - 11)  # exactly the packaged size
    (d / "plotly.min.js").write_bytes(evil)
    (root / "plotly.min.js").write_bytes(evil)  # and one in the folder above, which was hard-linked in
    (d / "tuner_report.js").write_text("alert(2)")
    out = run_tuner("report", d)
    assert out.returncode == 0, out.stderr
    assert _sha(d / "plotly.min.js") == _sha(src) and not (d / "plotly.min.js").samefile(root / "plotly.min.js")
    from importlib import resources

    assert (d / "tuner_report.js").read_bytes() == resources.files("tuner").joinpath("static/tuner_report.js") \
        .read_bytes()
    shutil.copyfile(src, root / "plotly.min.js")  # a genuine copy above, the user's own: linked, not copied
    os.chmod(root / "plotly.min.js", 0o644)
    (d / "plotly.min.js").unlink()
    assert run_tuner("report", d).returncode == 0
    assert (d / "plotly.min.js").samefile(root / "plotly.min.js")


# --- what may load code ---------------------------------------------------------------------------------
PLANT = """import pathlib
pathlib.Path({marker!r}).write_text('imported')
import numpy as np
_calls = []


def dynamics(x, u, t, params):
    _calls.append(0)  # a Python list: numba does not compile it, so no compile time in the test
    return np.array([-x[0] + u[0]])
"""


@pytest.fixture(scope="module")
def plant_run(tmp_path_factory):
    """A finished closed-loop run on a plant in Python dynamics, its module beside its config."""
    tmp = tmp_path_factory.mktemp("plant")
    (tmp / "plant_h.py").write_text(PLANT.format(marker=str(tmp / "UNUSED")))
    raw = {"name": "p", "seed": 1, "objective": {
        "kind": "closed_loop", "plant": {"python": "plant_h:dynamics", "x0": [0.0], "n_sub": 1},
        "controller": "pid2dof", "period_s": 0.05, "fixed": {"Td_s": 0.0},
        "scenario": {"duration_s": 0.5, "reference": [{"t": 0.05, "value": 1.0}]}},
        "optimizer": {"method": "pso", "population": 2, "generations": 2}, "parallel": {"backend": "serial"}}
    res = run(config_from_dict(raw, base_dir=tmp), run_dir=tmp / "run", quiet=True, report=False)
    assert res.status == "finished"
    sys.modules.pop("plant_h", None)
    with contextlib.suppress(ValueError):
        sys.path.remove(str(tmp))
    return res.run_dir


def _handed_plant_run(plant_run, tmp_path, keep_base_dir=False) -> tuple[Path, Path]:
    """The run handed over with its plant module inside it and base_dir (or none) pointing there; meta.json's
    config hash and the unkeyed history chain recomputed, as the sender can."""
    d = tmp_path / "handed"
    shutil.copytree(plant_run, d)
    marker = tmp_path / "IMPORTED"
    (d / "plant_h.py").write_text(PLANT.format(marker=str(marker)))
    cfg = yaml.safe_load((d / "config.yaml").read_text())
    if keep_base_dir:
        cfg["base_dir"] = str(d)
    else:
        cfg.pop("base_dir")
    (d / "config.yaml").write_text(yaml.safe_dump(cfg, sort_keys=False))
    meta = json.loads((d / "meta.json").read_text())
    (d / "meta.json").write_text(json.dumps({**meta, "config_hash": config_hash(cfg)}))
    (d / "history.chain").write_text(_chain(d, None))  # chained to the new config hash: anyone can
    (d / ".config.json").unlink()
    sys.modules.pop("plant_h", None)
    return d, marker


@pytest.mark.parametrize("keep_base_dir", [False, True])
def test_read_only_commands_never_import_a_plant_module_a_run_names(plant_run, tmp_path, keep_base_dir):
    d, marker = _handed_plant_run(plant_run, tmp_path, keep_base_dir)
    sweep_like = tmp_path / "folder"
    sweep_like.mkdir()
    for cmd in (["show", d], ["compare", d, d], ["report", d], ["list", "runs", "--dir", tmp_path],
                ["dashboard", tmp_path], *[["export", d, "--format", f] for f in ("yaml", "json", "python", "c")]):
        out = run_tuner(*cmd, cwd=sweep_like)
        assert out.returncode == 0 and "Traceback" not in out.stderr, (cmd, out.stderr)
        assert not marker.exists(), f"`tuner {cmd[0]}` imported the run's plant module"
    exported = yaml.safe_load(run_tuner("export", d).stdout)
    assert set(exported["params"]) >= {"K", "Ti_s"} and exported["tables"], exported  # recorded by the run
    import tuner

    res = tuner.load(d)
    assert res.best and not marker.exists()


@pytest.mark.parametrize("keep_base_dir", [False, True])
def test_code_commands_refuse_a_plant_module_inside_the_run_directory(plant_run, tmp_path, keep_base_dir):
    d, marker = _handed_plant_run(plant_run, tmp_path, keep_base_dir)
    for cmd in (["evaluate", d], ["cv", d, "-q", "--k", "2"]):
        one_error(run_tuner(*cmd), "objective.plant.python", "inside the run directory", "your own")
    _interrupted(d)
    one_error(run_tuner("resume", d, "-q"), "objective.plant.python", "inside the run directory")
    import tuner
    from tuner.config import ConfigError

    res = tuner.load(d)
    with pytest.raises(ConfigError, match="inside the run directory"):
        res.build()
    assert not marker.exists()


@pytest.mark.slow
def test_a_handed_over_sweep_report_never_imports_its_plant_module(plant_run, tmp_path):
    """`tuner report SWEEP_DIR` rebuilt every job's objective for its response figure, importing the plant
    module the jobs' configs named, from inside the sweep directory."""
    cfg = yaml.safe_load((plant_run / "config.yaml").read_text())
    base = {k: cfg[k] for k in ("name", "objective", "optimizer", "parallel")}
    (tmp_path / "plant_h.py").write_text(PLANT.format(marker=str(tmp_path / "UNUSED")))
    (tmp_path / "sw.yaml").write_text(yaml.safe_dump({"sweep": {"name": "sw", "base": base, "seeds": [1, 2]}}))
    out = run_tuner("sweep", tmp_path / "sw.yaml", "--dir", tmp_path / "sweep", "-q", "--no-report")
    assert out.returncode == 0, out.stderr
    sys.modules.pop("plant_h", None)
    handed = tmp_path / "handed"
    shutil.copytree(tmp_path / "sweep", handed)
    marker = tmp_path / "IMPORTED"
    (handed / "plant_h.py").write_text(PLANT.format(marker=str(marker)))
    for job in (handed / "jobs").iterdir():
        if job.is_dir():
            c = yaml.safe_load((job / "config.yaml").read_text())
            (job / "config.yaml").write_text(yaml.safe_dump({**c, "base_dir": str(handed)}, sort_keys=False))
    for cmd in (["report", handed], ["show", handed], ["dashboard", tmp_path]):
        res = run_tuner(*cmd)
        assert res.returncode == 0 and "Traceback" not in res.stderr, (cmd, res.stderr)
        assert not marker.exists(), f"`tuner {cmd[0]}` imported the plant module of a handed-over sweep"
    _interrupted(handed / "jobs" / "seed-1")  # the sweep run again resumes it: not with the code inside it
    c = yaml.safe_load((handed / "jobs" / "seed-1" / "config.yaml").read_text())
    meta = json.loads((handed / "jobs" / "seed-1" / "meta.json").read_text())
    (handed / "jobs" / "seed-1" / "meta.json").write_text(json.dumps({**meta, "config_hash": config_hash(c)}))
    (handed / "jobs" / "seed-1" / "history.chain").write_text(_chain(handed / "jobs" / "seed-1", None))
    one_error(run_tuner("resume", handed / "jobs" / "seed-1", "-q"), "inside the run directory", str(handed))
    assert not marker.exists()
    sys.modules.pop("plant_h", None)


def test_the_user_opts_in_with_a_config_of_their_own(plant_run, tmp_path):
    """The way the refusals point to: the module copied out beside a config of the user's."""
    d, marker = _handed_plant_run(plant_run, tmp_path)
    mine = tmp_path / "mine"
    mine.mkdir()
    shutil.copy(d / "plant_h.py", mine / "plant_h.py")
    cfg = yaml.safe_load((d / "config.yaml").read_text())
    for k in ("source", "parameters"):
        cfg.pop(k, None)
    (mine / "job.yaml").write_text(yaml.safe_dump(cfg))
    out = run_tuner("evaluate", mine / "job.yaml", "--params", d / "best.yaml")
    assert out.returncode == 0 and out.stdout.startswith("fitness:"), out.stderr
    assert marker.exists()  # the code ran, because the user pointed at it
    sys.modules.pop("plant_h", None)


# --- small ones -------------------------------------------------------------------------------------------
def test_tune_reraises_keyboard_interrupt_after_saving(tmp_path):
    import tuner

    def stop(summary):
        if summary.generation == 1:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        tuner.tune(sphere_job(tmp_path, 'h', optimizer={"method": "pso", "population": 4, "generations": 10}),
                   run_dir=tmp_path / "r", progress=False, callback=stop, report=False)
    res = tuner.load(tmp_path / "r")
    assert res.status == "interrupted" and res.n_evals == 8


def test_a_run_whose_every_evaluation_failed_is_not_finished(tmp_path):
    job = failing_python_job(tmp_path, "failall_h", "RuntimeError('always')")
    out = run_tuner("run", job, "--run-dir", tmp_path / "runs" / "r", "-q", "--no-report")
    assert out.returncode == 1 and "every one of 12 evaluations failed" in out.stderr, out.stderr
    meta = json.loads((tmp_path / "runs" / "r" / "meta.json").read_text())
    assert meta["status"] == "failed" and "every one of 12" in meta["stop_reason"]
    from tuner.dashboard import collect_runs

    assert [r["status"] for r in collect_runs(tmp_path / "runs")] == ["failed"]
    one_error(run_tuner("resume", tmp_path / "runs" / "r"), "every evaluation failed")
    sys.modules.pop("failall_h", None)


def test_one_damaged_run_is_listed_as_unreadable_in_the_dashboard(tmp_path, finished):
    root = tmp_path / "runs"
    for name in ("a", "b", "c"):
        shutil.copytree(finished, root / name)
    (root / "b" / "meta.json").write_text("{not json")
    (root / "c" / "best.yaml").unlink()
    (root / "c" / "best.yaml").symlink_to(root / "a" / "best.yaml")  # refused as the directory is opened
    out = run_tuner("dashboard", root)
    assert out.returncode == 0, out.stderr
    from tuner.dashboard import collect_runs

    rows = {r["id"]: r["status"] for r in collect_runs(root)}
    assert rows["a"] == "finished" and rows["b"].startswith("unreadable: ") and "meta.json" in rows["b"], rows
    assert rows["c"].startswith("unreadable: ") and "symbolic link" in rows["c"], rows


def test_a_stopped_dashboard_leaves_no_temporary_file(tmp_path, finished, monkeypatch):
    root = tmp_path / "runs"
    shutil.copytree(finished, root / "a")
    real = os.replace

    def stop(src, dst):  # SIGTERM (KeyboardInterrupt in tuner) just before the page is renamed into place
        if str(dst).endswith("index.html"):
            raise KeyboardInterrupt
        return real(src, dst)

    monkeypatch.setattr(os, "replace", stop)
    out = run_tuner("dashboard", root)
    monkeypatch.undo()
    assert out.returncode == 1 and "interrupted" in out.stderr
    assert not [p for p in root.rglob("*") if ".tmp" in p.name], sorted(root.rglob("*"))


def test_the_dashboard_over_several_runs_folders_shows_every_sweep_job(tmp_path):
    (tmp_path / "base.yaml").write_text(yaml.safe_dump(sphere_job(tmp_path, 'h')))
    (tmp_path / "sw.yaml").write_text(yaml.safe_dump({"sweep": {"name": "sw", "base": "base.yaml", "seeds": [1, 2]}}))
    parent = tmp_path / "parent"
    for proj in ("p1", "p2"):
        out = run_tuner("sweep", tmp_path / "sw.yaml", "--dir", parent / proj / "runs" / "sweeps" / "sw", "-q",
                        "--no-report")
        assert out.returncode == 0, out.stderr
    from tuner.dashboard import collect_runs

    rows = {r["id"]: r for r in collect_runs(parent)}
    for proj in ("p1", "p2"):
        sw = rows[f"{proj}/runs/sweeps/sw"]
        assert sw["status"] == "finished" and sw["n_evals"] == 24, sw
        assert {f"{proj}/runs/sweeps/sw/jobs/seed-{s}" for s in (1, 2)} <= set(rows)


def test_sweep_set_overrides_every_job(tmp_path):
    (tmp_path / "base.yaml").write_text(yaml.safe_dump(sphere_job(tmp_path, 'h')))
    (tmp_path / "sw.yaml").write_text(yaml.safe_dump({"sweep": {"name": "sw", "base": "base.yaml", "seeds": [1, 2],
                                                                "grid": {"optimizer.population": [4, 6]}}}))
    out = run_tuner("sweep", tmp_path / "sw.yaml", "--dir", tmp_path / "o", "-q", "--no-report",
                    "--set", "optimizer.generations=1")
    assert out.returncode == 0, out.stderr
    for job in (tmp_path / "o" / "jobs").iterdir():
        if job.is_dir():
            assert yaml.safe_load((job / "config.yaml").read_text())["optimizer"]["generations"] == 1
    assert "--set optimizer.generations=1" in (tmp_path / "o" / "command.txt").read_text()
    one_error(run_tuner("sweep", tmp_path / "sw.yaml", "--dir", tmp_path / "o", "-q", "--set",
                        "optimizer.generations=2"), "another configuration")


@pytest.mark.slow
def test_sigterm_to_a_parallel_sweep_marks_its_jobs_interrupted(tmp_path):
    import subprocess
    import time

    slow = sphere_job(tmp_path, 'h', objective={"kind": "function", "function": "sphere", "dim": 2, "sleep_s": 0.05},
                optimizer={"method": "pso", "population": 4, "generations": 200})
    (tmp_path / "base.yaml").write_text(yaml.safe_dump(slow))
    (tmp_path / "sw.yaml").write_text(yaml.safe_dump({"sweep": {"name": "sw", "base": "base.yaml", "seeds": [1, 2]}}))
    p = subprocess.Popen([sys.executable, "-m", "tuner", "sweep", str(tmp_path / "sw.yaml"), "--dir",
                          str(tmp_path / "o"), "--jobs", "2", "-q"], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                         text=True)
    metas = [tmp_path / "o" / "jobs" / f"seed-{s}" / "meta.json" for s in (1, 2)]
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline:
        try:
            if all(json.loads(m.read_text()).get("generations", 0) >= 1 for m in metas):
                break
        except (OSError, ValueError):
            pass
        time.sleep(0.2)
    p.send_signal(signal.SIGTERM)
    _, err = p.communicate(timeout=120)
    assert p.returncode == 1 and "Traceback" not in err, err
    assert [json.loads(m.read_text())["status"] for m in metas] == ["interrupted", "interrupted"]
