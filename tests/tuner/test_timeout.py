"""Unbounded and misbehaving evaluations: timeout_s, SystemExit, KeyboardInterrupt, dead loky workers."""

import csv
import os
import signal
import subprocess
import sys
import time

import pytest
import yaml

OBJ = '''
import os, signal, time
CALLS = []
def f(p, mode="ok"):
    a = p["a"]
    CALLS.append(a)
    if mode == "swallow" and len(CALLS) == 3:  # the user's Ctrl-C, caught by the objective's own code
        try:
            os.kill(os.getpid(), signal.SIGINT)
            time.sleep(5)
        except KeyboardInterrupt:
            pass
    # Ctrl-C in generation 2, after the report modules broke (half-imported); the default-parameter check of a
    # `kind: python` objective runs in a child process, so calls 1-2 of this process are generation 1
    if mode == "brokenreport" and len(CALLS) == 3:
        import sys
        sys.modules["tuner.report"] = None
        os.kill(os.getpid(), signal.SIGINT)
        time.sleep(5)
    if mode == "hang" and a > 0.8:
        time.sleep(3600)
    if mode == "exit" and a > 0.7:
        raise SystemExit(3)
    if mode == "kbd" and a > 0.7:
        raise KeyboardInterrupt
    if mode == "crash" and a > 0.85:
        os._exit(1)
    if mode == "slow":
        time.sleep(0.2)
    return (a - 0.3) ** 2 + p["b"] ** 2
'''


def job(tmp_path, mode, backend="serial", n_jobs=1, timeout_s=None, pop=8, gens=3, name="t"):
    (tmp_path / "userobj.py").write_text(OBJ)
    obj = {"kind": "python", "callable": "userobj:f", "options": {"mode": mode}}
    if timeout_s:
        obj["timeout_s"] = timeout_s
    cfg = {"name": name, "seed": 4, "objective": obj,
           "parameters": {"a": {"low": 0.0, "high": 1.0}, "b": {"low": -1.0, "high": 1.0}},
           "optimizer": {"method": "pso", "population": pop, "generations": gens},
           "parallel": {"backend": backend, "n_jobs": n_jobs}, "output": str(tmp_path / "runs")}
    p = tmp_path / f"{name}.yaml"
    p.write_text(yaml.safe_dump(cfg))
    return p


def run(tmp_path, p, *extra):
    env = {**os.environ, "PYTHONPATH": str(tmp_path)}
    return subprocess.run([sys.executable, "-m", "tuner", "run", str(p), *extra], capture_output=True, text=True,
                          cwd=tmp_path, timeout=300, env=env)


def history(out):
    rd = out.stdout.split("run directory: ")[1].split()[0]
    return list(csv.DictReader(open(f"{rd}/history.csv")))


@pytest.mark.parametrize("backend, n_jobs", [("serial", 1), ("loky", 2)])
@pytest.mark.slow
def test_timed_out_evaluations_are_recorded_failures(tmp_path, backend, n_jobs):
    t0 = time.perf_counter()
    out = run(tmp_path, job(tmp_path, "hang", backend, n_jobs, timeout_s=1.0), "--no-report")
    assert out.returncode == 0, out.stderr
    rows = history(out)
    hung = [r for r in rows if float(r["a"]) > 0.8]
    assert hung and all(r["status"] == "failed" and r["error"].startswith("timeout: no result after 1 s")
                        for r in hung)
    assert all(r["status"] == "ok" for r in rows if float(r["a"]) <= 0.8)
    assert time.perf_counter() - t0 < 60 + 2 * len(hung)


@pytest.mark.slow
def test_timeout_changes_no_result_and_serial_equals_loky(tmp_path):
    ref = history(run(tmp_path, job(tmp_path, "ok", name="ref"), "--no-report"))
    for backend, n in (("serial", 1), ("loky", 2)):
        rows = history(run(tmp_path, job(tmp_path, "ok", backend, n, timeout_s=30, name=f"t{backend}"), "--no-report"))
        assert [(r["a"], r["b"], r["fitness"]) for r in rows] == [(r["a"], r["b"], r["fitness"]) for r in ref]


def test_timeout_must_be_positive(tmp_path):
    out = run(tmp_path, job(tmp_path, "ok", timeout_s=-1))
    assert out.returncode == 2 and "objective.timeout_s: expected a number of seconds > 0, got -1" in out.stderr


@pytest.mark.parametrize("mode, error", [("exit", "SystemExit: 3"), ("kbd", "KeyboardInterrupt")])
@pytest.mark.slow
def test_systemexit_and_keyboardinterrupt_raised_by_the_objective_are_failures(tmp_path, mode, error):
    out = run(tmp_path, job(tmp_path, mode), "--no-report")
    assert out.returncode == 0, out.stderr
    rows = history(out)
    bad = [r for r in rows if float(r["a"]) > 0.7]
    assert bad and all(r["status"] == "failed" and r["error"].startswith(error) for r in bad)
    assert "status: finished" in out.stdout


def test_ctrl_c_from_the_user_still_interrupts(tmp_path):
    p = job(tmp_path, "slow", pop=4, gens=50)
    env = {**os.environ, "PYTHONPATH": str(tmp_path)}
    proc = subprocess.Popen([sys.executable, "-m", "tuner", "run", str(p), "--no-report"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=tmp_path, env=env)
    deadline = time.time() + 60
    while time.time() < deadline and not list((tmp_path / "runs").glob("*/history.csv")):
        time.sleep(0.2)
    time.sleep(0.5)
    proc.send_signal(signal.SIGINT)
    stdout, stderr = proc.communicate(timeout=60)
    assert proc.returncode == 1, stderr
    assert "status: interrupted" in stdout and "tuner resume" in stderr


def test_ctrl_c_swallowed_by_the_objective_stops_the_run_at_the_generation_end(tmp_path):
    """A KeyboardInterrupt that never reaches the run (caught by the objective, or raised in a
    ``__del__``) still stops it: the run counts SIGINTs and checks the count after each generation."""
    out = run(tmp_path, job(tmp_path, "swallow", pop=4, gens=5), "--no-report")
    assert out.returncode == 1, out.stderr
    assert "status: interrupted" in out.stdout and "tuner resume" in out.stderr
    assert len(history(out)) == 4  # the generation in progress is completed and kept


def test_ctrl_c_ends_the_run_as_interrupted_even_when_the_report_cannot_be_imported(tmp_path):
    """A Ctrl-C that lands inside the report's first import leaves pandas half-initialised; the final report
    of the interrupted run then fails to import. That is a warning, not a traceback: the run still ends
    `interrupted`, resumable, with what it computed."""
    out = run(tmp_path, job(tmp_path, "brokenreport", pop=2, gens=5))
    assert out.returncode == 1, out.stderr
    assert "status: interrupted" in out.stdout and "tuner resume" in out.stderr
    assert "warning: live report not written" in out.stderr and "Traceback" not in out.stderr
    assert len(history(out)) == 2  # the first generation, kept


@pytest.mark.slow
def test_a_crashed_loky_worker_gives_recorded_failures(tmp_path):
    out = run(tmp_path, job(tmp_path, "crash", "loky", 2), "--no-report")
    assert out.returncode == 0, out.stderr
    rows = history(out)
    dead = [r for r in rows if float(r["a"]) > 0.85]
    assert dead and all(r["status"] == "failed" and "worker process died" in r["error"] for r in dead)
    ok = [r for r in rows if float(r["a"]) <= 0.85]
    assert ok and all(r["status"] == "ok" for r in ok)
