"""The run directory as a trust and consistency boundary: no code from it, one process at a time,
refused edits, typed errors, per-evaluation seeds."""

import json
import os
import pickle
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import yaml

import tuner.run as run_mod
from tests.conftest import run_tuner
from tests.tuner.jobs import rastrigin_job
from tuner.config import ConfigError
from tuner.digest import row_digest
from tuner.loop import evaluation_seed, minimize
from tuner.objective import Evaluation
from tuner.optimizers import get_optimizer
from tuner.run import resume, run
from tuner.rundir import RunDir, RunError
from tuner.space import Real, Space

ROOT = Path(__file__).resolve().parents[2]


def job(tmp_path, **over):
    return rastrigin_job(tmp_path, 3, 6, 4, **over)


def history(run_dir):
    return pd.read_csv(Path(run_dir) / "history.csv", keep_default_na=False).drop(columns="seconds")


def interrupted_run(cfg, run_dir, after_gens=2, report=False):
    """A real run interrupted (as by Ctrl-C) after ``after_gens`` progress lines; without its report unless
    ``report``."""
    seen = []

    def progress(msg):
        seen.append(msg)
        if " gen " in f" {msg} " and sum(" gen " in f" {m} " for m in seen) == after_gens:
            raise KeyboardInterrupt

    res = run(cfg, run_dir=run_dir, progress=progress, report=report)
    assert res.status == "interrupted"
    return res


def tuner_cli(*args):
    return run_tuner(*args, cwd=ROOT)


# --- 13.1: nothing from a run directory is executed ------------------------------------------
class _Boom:
    def __init__(self, marker):
        self.marker = marker

    def __reduce__(self):  # unpickling this runs a shell command that creates the marker file
        return os.system, (f"touch {self.marker}",)


def test_crafted_pickle_checkpoint_is_never_loaded(tmp_path):
    d = tmp_path / "r"
    interrupted_run(job(tmp_path), d, report=True)  # its report among the files checked for pickles below
    marker = tmp_path / "pwned"
    (d / "checkpoint.pkl").write_bytes(pickle.dumps({"optimizer": _Boom(marker)}))
    assert not marker.exists()
    with pytest.raises(RunError, match="checkpoint.pkl.*never loaded.*cannot be resumed"):
        resume(d, quiet=True)
    out = tuner_cli("resume", str(d))
    assert out.returncode == 2 and "cannot be resumed" in out.stderr and "Traceback" not in out.stderr
    assert not marker.exists(), "the crafted pickle ran"
    # the run's own files carry no pickle at all
    assert not any(p.suffix in (".pkl", ".pickle") for p in d.rglob("*") if p.name != "checkpoint.pkl")


def test_resume_replays_history_and_refuses_an_edited_one(tmp_path):
    ref = run(job(tmp_path, optimizer={"method": "cmaes"}), run_dir=tmp_path / "ref", quiet=True, report=False)
    d = tmp_path / "r"
    interrupted_run(job(tmp_path, optimizer={"method": "cmaes"}), d)
    ck = json.loads((d / "checkpoint.json").read_text())
    assert set(ck) == {"n_evals", "stage", "generations", "version"}  # data only: a row count
    res = resume(d, quiet=True, report=False)
    pd.testing.assert_frame_equal(history(ref.run_dir), history(d))
    assert res.best_params == ref.best_params and res.best_fitness == ref.best_fitness

    e = tmp_path / "e"
    interrupted_run(job(tmp_path), e)
    h = pd.read_csv(e / "history.csv", keep_default_na=False, dtype=str)
    h.loc[2, "x1"] = "0.5"
    h.to_csv(e / "history.csv", index=False)
    with pytest.raises(RunError, match=r"history.csv: row eval=2: does not match its digest.*edited"):
        resume(e, quiet=True)
    (e / "history.chain").unlink()  # a history without its chain is not used
    with pytest.raises(RunError, match=r"history.chain: missing beside history.csv"):
        resume(e, quiet=True)
    # the unkeyed chain recomputed over the edit, as anyone can: the replay itself still finds the edit
    rows, lines = pd.read_csv(e / "history.csv", keep_default_na=False, dtype=str), []
    prev = json.loads((e / "meta.json").read_text())["config_hash"]
    for r in rows.to_dict("records"):
        prev = row_digest(prev, r)
        lines.append(f"{r['eval']},{prev}\n")
    (e / "history.chain").write_text("".join(lines))
    with pytest.raises(RunError, match=r"history.csv: row eval=2: x1 is '0.5'.*edited"):
        resume(e, quiet=True)


# --- 13.3: one process per run directory --------------------------------------------------------
def test_second_process_on_a_running_directory_fails_at_once(tmp_path):
    cfg = {"name": "lock", "seed": 1, "objective": {"kind": "function", "function": "sphere", "dim": 2,
                                                     "sleep_s": 0.05},
           "optimizer": {"method": "pso", "population": 4, "generations": 40}, "parallel": {"backend": "serial"}}
    job_file = tmp_path / "lock.yaml"
    job_file.write_text(yaml.safe_dump(cfg))
    d = tmp_path / "r"
    first = subprocess.Popen([sys.executable, "-m", "tuner", "run", str(job_file), "--run-dir", str(d), "-q",
                              "--no-report"],
                             cwd=ROOT, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        deadline = time.time() + 60
        while not (d / "checkpoint.json").exists() and time.time() < deadline:
            time.sleep(0.02)
        for args in (["run", str(job_file), "--run-dir", str(d)], ["resume", str(d)]):
            t0 = time.time()
            out = tuner_cli(*args)
            assert out.returncode == 2, out.stderr
            assert f"error: {d}: in use by pid {first.pid}" in out.stderr
            assert time.time() - t0 < 30
        assert first.poll() is None, "the first run must still be going"
    finally:
        first.kill()
        first.wait()
    h = pd.read_csv(d / "history.csv")
    assert h["eval"].is_unique and (h["eval"].to_numpy() == np.arange(len(h))).all()


# --- 13.5: a changed config is refused on resume ------------------------------------------------
def test_resume_refuses_changed_config_naming_the_key(tmp_path):
    d = tmp_path / "r"
    interrupted_run(job(tmp_path), d)
    meta = json.loads((d / "meta.json").read_text())
    assert len(meta["config_hash"]) == 64
    original = (d / "config.yaml").read_text()
    doc = yaml.safe_load(original)
    doc["optimizer"]["population"] = 10
    (d / "config.yaml").write_text(yaml.safe_dump(doc, sort_keys=False))
    with pytest.raises(RunError, match=r"config.yaml: changed since the run started.*`optimizer.population`"):
        resume(d, quiet=True)
    doc = yaml.safe_load(original)
    doc["parameters"]["x0"]["high"] = 1.0
    (d / "config.yaml").write_text(yaml.safe_dump(doc, sort_keys=False))
    out = tuner_cli("resume", str(d))
    assert out.returncode == 2 and "parameters.x0.high" in out.stderr and "Traceback" not in out.stderr
    (d / "config.yaml").write_text(original)
    assert resume(d, quiet=True, report=False).status == "finished"


# --- 13.6 (run-directory part): corrupt files give one error line --------------------------------
@pytest.mark.parametrize("name,text,expect", [
    ("meta.json", "{not json", "meta.json: not valid JSON"),
    ("meta.json", json.dumps({"status": "weird", "name": "t", "seed": 1}), "meta.json: status: expected one of"),
    ("meta.json", None, "meta.json: missing"),
    ("best.yaml", "params: [1, 2", "best.yaml: not valid YAML"),
    ("best.yaml", "fitness: 1.0\n", "best.yaml: params: missing"),
    ("config.yaml", "- a list\n", "config.yaml: expected a mapping"),
])
@pytest.mark.slow
def test_corrupt_run_files_are_one_error_line(tmp_path, name, text, expect):
    d = run(job(tmp_path), run_dir=tmp_path / "r", quiet=True, report=False).run_dir
    if text is None:
        (d / name).unlink()
    else:
        (d / name).write_text(text)
    if name == "config.yaml":
        meta = json.loads((d / "meta.json").read_text())
        (d / "meta.json").write_text(json.dumps({**meta, "status": "interrupted"}))
    commands = {"meta.json": [["show", d], ["compare", d, d], ["report", d], ["export", d], ["resume", d],
                              ["list", "runs", "--dir", tmp_path]],
                "best.yaml": [["show", d], ["compare", d], ["report", d], ["export", d],
                              ["list", "runs", "--dir", tmp_path]],
                "config.yaml": [["resume", d], ["export", d]]}[name]
    if name == "meta.json" and text is None:  # no meta.json: show/report say it is not a run directory
        commands = [["compare", d], ["export", d], ["resume", d]]
    for cmd in commands:
        out = tuner_cli(*map(str, cmd))
        if cmd[0] == "list":  # one damaged run is listed as unreadable, with the reason; the others as usual
            assert out.returncode == 0 and "Traceback" not in out.stderr, (cmd, out.stderr)
            assert f"unreadable: r: {d}" in out.stdout and expect in out.stdout, out.stdout
            continue
        assert out.returncode == 2, (cmd, out.stdout, out.stderr)
        assert "Traceback" not in out.stderr and out.stderr.startswith("error: "), (cmd, out.stderr)
        assert expect in out.stderr or (cmd[0] == "export" and "no best.yaml" in out.stderr), (cmd, out.stderr)


# --- 13.9 ---------------------------------------------------------------------------------------
def test_report_shows_final_status_and_notes_capped_workers(tmp_path):
    res = run(job(tmp_path, optimizer={"population": 3, "generations": 2},
                  parallel={"backend": "loky", "n_jobs": 64}), run_dir=tmp_path / "r", quiet=True)
    text = (res.run_dir / "report.md").read_text()
    assert "| status | finished" in text
    meta = json.loads((res.run_dir / "meta.json").read_text())
    assert meta["n_jobs_requested"] == 64 and meta["n_jobs"] == min(3, os.cpu_count())
    assert any("capped at the population 3" in n for n in meta["notes"])
    assert "capped at the population 3" in text


def test_bad_options_leave_no_directory(tmp_path):
    d = tmp_path / "nothing"
    with pytest.raises(ConfigError, match="optimizer"):
        run(job(tmp_path, optimizer={"method": "cmaes", "population": 1}), run_dir=d, quiet=True)
    assert not d.exists()
    with pytest.raises(ConfigError):
        run(job(tmp_path, optimizer={"method": "de", "population": 2}), quiet=True)
    assert not (tmp_path / "runs").exists()


@pytest.mark.slow
def test_directory_killed_before_meta_is_reused_or_resumed(tmp_path):
    cfg = job(tmp_path)
    ref = run(cfg, run_dir=tmp_path / "ref", quiet=True, report=False)
    d = tmp_path / "unstarted"
    d.mkdir()
    (d / ".config.yaml.tmp123").write_text("half")
    lines = []
    res = run(cfg, run_dir=d, progress=lines.append, report=False)
    assert res.best_fitness == ref.best_fitness and not list(d.glob(".*.tmp*"))
    # only config.yaml written: resume starts it from the beginning and says so
    e = tmp_path / "e"
    e.mkdir()
    (e / "config.yaml").write_text((ref.run_dir / "config.yaml").read_text())
    lines = []
    res = resume(e, progress=lines.append, report=False)
    assert any("no meta.json" in m and "from the beginning" in m for m in lines)
    pd.testing.assert_frame_equal(history(ref.run_dir), history(e))
    # an empty directory: the message says how to reuse it
    f = tmp_path / "f"
    f.mkdir()
    with pytest.raises(RunError, match=r"tuner run CONFIG --run-dir"):
        resume(f, quiet=True)


# --- per-evaluation seed (STYLE rule 5) ----------------------------------------------------------
@dataclass(frozen=True)
class Noisy:
    """A stochastic objective: sphere plus noise drawn from the evaluation's own seed."""

    takes_seed = True

    def __call__(self, params, seed):
        rng = np.random.default_rng(seed)
        x = np.array([params[k] for k in sorted(params)])
        return Evaluation(float(x @ x + rng.normal()), {"seed": seed})


def _noisy_build(cfg):
    return Noisy(), Space(Real(f"x{i}", -2.0, 2.0) for i in range(3))


@pytest.mark.parametrize("method", ["pso", "cmaes"])
@pytest.mark.slow
def test_stochastic_objective_same_history_serial_loky_and_resumed(tmp_path, monkeypatch, method):
    monkeypatch.setattr(run_mod, "_build", _noisy_build)
    a = run(job(tmp_path, optimizer={"method": method, "refine": {"stages": 2, "shrink": 0.5}}),
            run_dir=tmp_path / "a", quiet=True, report=False)
    b = run(job(tmp_path, optimizer={"method": method, "refine": {"stages": 2, "shrink": 0.5}},
                parallel={"backend": "loky", "n_jobs": 2}), run_dir=tmp_path / "b", quiet=True, report=False)
    c = tmp_path / "c"
    interrupted_run(job(tmp_path, optimizer={"method": method, "refine": {"stages": 2, "shrink": 0.5}}), c,
                    after_gens=3)
    resume(c, quiet=True, report=False)
    ha, hb, hc = history(a.run_dir), history(b.run_dir), history(c)
    pd.testing.assert_frame_equal(ha, hb)
    pd.testing.assert_frame_equal(ha, hc)
    # evaluation i got the seed derived from (run seed 3, i), independently recomputed here
    want = [int(np.random.SeedSequence(3, spawn_key=(0x65766C, i)).generate_state(1, np.uint64)[0] >> 1)
            for i in range(len(ha))]
    assert [int(s) for s in ha["seed"]] == want == [evaluation_seed(3, i) for i in range(len(ha))]
    assert len(set(want)) == len(want)


def test_minimize_is_a_plain_loop_with_typed_result():
    space = Space(Real(f"x{i}", -1.0, 1.0) for i in range(2))
    opt = get_optimizer("de")(2, np.random.default_rng(0), population=8, generations=15)
    calls = []
    res = minimize(lambda p: calls.append(p) or (p["x0"] - 0.3) ** 2 + p["x1"] ** 2, space, opt,
                   callback=lambda g: calls.append(g.stats))
    assert res.n_evals == 120 == sum(isinstance(c, dict) for c in calls)
    assert len(res.convergence) == 15 and res.stop_reason == "15 generations"
    best = [c.best for c in res.convergence]
    assert all(b1 <= b0 for b0, b1 in zip(best, best[1:]))  # best never worsens
    assert res.best.fitness == best[-1] == min((p["x0"] - 0.3) ** 2 + p["x1"] ** 2
                                               for p in calls if isinstance(p, dict))
    assert res.best.fitness < 1e-3


def test_rundir_typed_records_round_trip(tmp_path):
    d = run(job(tmp_path), run_dir=tmp_path / "r", quiet=True, report=False).run_dir
    rd = RunDir(d)
    meta, best = rd.meta(), rd.best()
    assert meta.status == "finished" and meta.n_evals == 24 and meta.timing.sessions == 1
    assert type(meta).from_dict(json.loads(json.dumps(meta.to_dict())), d) == meta
    h = pd.read_csv(d / "history.csv")
    assert best.fitness == h["fitness"].min() and best.eval == int(h["fitness"].idxmin())
    assert rd.checkpoint().n_evals == 24


def test_sweep_job_holds_the_lock_of_its_run_directory(tmp_path):
    from tuner.sweep import load_sweep, run_sweep

    doc = {"sweep": {"name": "s", "base": {"name": "f", "seed": 0, "objective": {"kind": "function",
                                                                                  "function": "sphere", "dim": 2},
                                           "optimizer": {"method": "pso", "population": 4, "generations": 2},
                                           "parallel": {"backend": "serial"}},
                     "variants": {"pso": {}}, "seeds": [1]}}
    p = tmp_path / "sweep.yaml"
    p.write_text(yaml.safe_dump(doc))
    job_id = load_sweep(p)["jobs"][0]["id"]
    job_dir = tmp_path / "out" / "jobs" / job_id
    with RunDir(job_dir).lock():  # another process running this job (flock conflicts across descriptors)
        with pytest.raises(RunError, match=f"{job_dir}: in use by pid {os.getpid()}"):
            run_sweep(p, sweep_dir=tmp_path / "out", quiet=True)
    res = run_sweep(p, sweep_dir=tmp_path / "out", quiet=True)
    assert res["ok"] and [r["action"] for r in res["results"]] == ["ran"]
