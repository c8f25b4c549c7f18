"""A handed-over run or sweep directory is data: links in it are refused (never followed, for reading or writing),
the read-only commands never import code it names, `python -m tuner` does not import from the working directory;
sweeps survive torn stamps, report all-failed jobs and do not depend on the working directory; YAML is bounded;
a full disk names the file."""

from __future__ import annotations

import os
import resource
import shutil
import signal
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

from tests.conftest import one_error_line as one_error
from tests.conftest import run_tuner
from tests.tuner.jobs import failing_python_job, sphere_job
from tuner.config import config_from_dict
from tuner.run import run

REPO = Path(__file__).resolve().parents[2]


def tuner(*args, cwd=None, env=None):
    return run_tuner(*args, cwd=cwd, env=env)  # in this process, or a new one for an environment





@pytest.fixture
def victim(tmp_path):
    p = tmp_path / "victim.txt"
    p.write_text("the user's own file\n")
    return p


def _copy(finished, tmp_path) -> Path:
    d = tmp_path / "handed"
    shutil.copytree(finished, d, symlinks=True)
    return d


def test_a_lock_link_is_refused_and_its_target_untouched(tmp_path, victim, finished):
    job = tmp_path / "job.yaml"
    job.write_text(yaml.safe_dump(sphere_job(tmp_path, 'u')))
    d = tmp_path / "empty"
    d.mkdir()
    (d / ".lock").symlink_to(victim)
    one_error(tuner("run", job, "--run-dir", d, "-q"), str(d / ".lock"), "symbolic link")
    h = _copy(finished, tmp_path)
    (h / ".lock").unlink(missing_ok=True)
    (h / ".lock").symlink_to(victim)
    for cmd in (["resume", h], ["cv", h], ["show", h], ["report", h]):
        one_error(tuner(*cmd), "symbolic link")
    assert victim.read_text() == "the user's own file\n"


@pytest.mark.parametrize("entry", ["history.csv", "best.yaml", "meta.json", "figures", "figures/convergence.png",
                                   "report.md"])
def test_linked_entries_are_never_read_or_written_through(tmp_path, victim, finished, entry):
    h = _copy(finished, tmp_path)
    target = h / entry
    if target.is_dir():
        shutil.rmtree(target)
        target.symlink_to(tmp_path)
    else:
        target.unlink()
        target.symlink_to(victim)
    before = sorted(p.name for p in tmp_path.iterdir())
    for cmd in (["show", h], ["report", h], ["export", h], ["compare", h, h], ["evaluate", h]):
        one_error(tuner(*cmd), "symbolic link", entry.split("/")[0])
    listed = tuner("list", "runs", "--dir", h.parent)  # the damaged run is listed as unreadable, saying why
    assert listed.returncode == 0 and "unreadable" in listed.stdout and "symbolic link" in listed.stdout
    assert victim.read_text() == "the user's own file\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == before


@pytest.mark.slow
def test_read_only_commands_never_import_the_code_a_run_names(tmp_path, monkeypatch):
    marker = tmp_path / "IMPORTED"
    code = f"import pathlib\npathlib.Path({str(marker)!r}).write_text('x')\ndef f(params):\n" \
           "    return (params['x'] - 0.25) ** 2\n"
    pkg = tmp_path / "pkg"
    pkg.mkdir()
    (pkg / "evilmod_u.py").write_text(code)
    monkeypatch.syspath_prepend(str(pkg))
    raw = sphere_job(tmp_path, 'u', objective={"kind": "python", "callable": "evilmod_u:f"},
               parameters={"x": {"low": 0.0, "high": 1.0}})
    res = run(config_from_dict(raw, base_dir=tmp_path), run_dir=tmp_path / "py", quiet=True, report=False)
    assert res.status == "finished"
    marker.unlink()
    cwd = tmp_path / "cwd"  # the module also lies in the working directory, beside the handed-over run
    cwd.mkdir()
    (cwd / "evilmod_u.py").write_text(code)
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    for cmd in (["show", res.run_dir], ["compare", res.run_dir, res.run_dir], ["report", res.run_dir],
                ["list", "runs", "--dir", tmp_path], *[["export", res.run_dir, "--format", f]
                                                       for f in ("yaml", "json", "python", "c")]):
        out = tuner(*cmd, cwd=cwd, env=env)
        assert out.returncode == 0, (cmd, out.stderr)
        assert not marker.exists(), f"`tuner {cmd[0]}` imported the run's module"
    ev = tuner("evaluate", res.run_dir, cwd=cwd, env=env)  # says it imports, and not from the working directory
    assert "imports and runs 'evilmod_u:f'" in ev.stderr
    one_error(ev, "cannot import 'evilmod_u:f'")
    assert not marker.exists()


def _sweep(tmp_path, base_over=None, seeds=(1,)) -> Path:
    (tmp_path / "base.yaml").write_text(yaml.safe_dump(sphere_job(tmp_path, 'u', **(base_over or {}))))
    p = tmp_path / "sw.yaml"
    p.write_text(yaml.safe_dump({"sweep": {"name": "sw", "base": "base.yaml", "seeds": list(seeds)}}))
    return p


def test_a_torn_job_stamp_reads_as_not_started(tmp_path):
    sw = _sweep(tmp_path)
    (tmp_path / "out" / "jobs").mkdir(parents=True)
    (tmp_path / "out" / "jobs" / ".seed-1.json").write_text("")  # a disk-full or kill left 0 bytes
    out = tuner("sweep", sw, "--dir", tmp_path / "out", "-q")
    assert out.returncode == 0, out.stderr


def test_a_job_with_every_evaluation_failed_is_reported_as_such(tmp_path):
    (tmp_path / "failall_u.py").write_text("def f(params):\n    if params['x'] == 0.5:\n        return 1.0\n"
                                           "    raise RuntimeError('always')\n")  # only the preflight's centre scores
    sw = _sweep(tmp_path, {"objective": {"kind": "python", "callable": "failall_u:f"},
                           "parameters": {"x": {"low": 0.0, "high": 1.0}}})
    out = tuner("sweep", sw, "--dir", tmp_path / "out", "-q", env={**os.environ, "PYTHONPATH": str(tmp_path)})
    assert "Traceback" not in out.stderr and out.returncode in (0, 1), out.stderr
    assert "all failed" in out.stdout
    show = tuner("show", tmp_path / "out")
    assert show.returncode == 0 and "all failed" in show.stdout, show.stderr
    assert "all failed" in (tmp_path / "out" / "report.md").read_text()


@pytest.mark.parametrize("jobs", ["0", "-2"])
def test_sweep_jobs_must_be_positive(tmp_path, jobs):
    one_error(tuner("sweep", _sweep(tmp_path), "--jobs", jobs, "--dir", tmp_path / "o"), "--jobs", ">= 1")
    assert not (tmp_path / "o").exists()


@pytest.mark.slow
def test_sweep_jobs_are_capped_and_the_directory_is_self_contained(tmp_path):
    _sweep(tmp_path, seeds=(1, 2))
    out = tuner("sweep", "sw.yaml", "--dir", "out", "--jobs", "64", cwd=tmp_path)
    assert out.returncode == 0, out.stderr
    assert "capped at 2" in out.stderr
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    for cmd in (["show", tmp_path / "out"], ["report", tmp_path / "out"]):
        r = tuner(*cmd, cwd=elsewhere)
        assert r.returncode == 0, (cmd, r.stderr)
    assert "seed-2" in tuner("show", tmp_path / "out", cwd=elsewhere).stdout


@pytest.mark.parametrize("text, what", [
    ("a: &a [x, x, x, x, x, x, x, x, x]\n" + "".join(
        f"{c}: &{c} [*{p}, *{p}, *{p}, *{p}, *{p}, *{p}, *{p}, *{p}, *{p}]\n"
        for p, c in zip("abcdefgh", "bcdefghi")), "alias bomb"),
    ("".join(f"a{i}: &a{i} {{k: 1}}\n" for i in range(101)) + "l: [" + ", ".join(f"*a{i}" for i in range(101)) + "]\n",
     "aliases"),
    ("name: " + "[" * 5000 + "]" * 5000 + "\n", "nested"),
    ("name: x\n  bad: [\n", "line"),
])
def test_yaml_bombs_and_errors_are_one_line(tmp_path, text, what):
    p = tmp_path / "bomb.yaml"
    p.write_text(text)
    for cmd in (["run", p], ["sweep", p], ["cv", p], ["evaluate", p]):
        one_error(tuner(*cmd), str(p), what)


def test_a_full_disk_names_the_file(tmp_path):
    job = tmp_path / "job.yaml"
    job.write_text(yaml.safe_dump(sphere_job(
        tmp_path, 'u', optimizer={"method": "pso", "population": 20, "generations": 60})))

    def small_files():  # files may not grow past 24 kB: the history hits it, as on a full disk
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
        resource.setrlimit(resource.RLIMIT_FSIZE, (24_000, 24_000))

    out = subprocess.run([sys.executable, "-m", "tuner", "run", str(job), "--run-dir", str(tmp_path / "r"), "-q",
                          "--no-report"], capture_output=True, text=True, timeout=300, preexec_fn=small_files)
    one_error(out, "error: " + str(tmp_path / "r"), "File too large")
    assert "error: ?" not in out.stderr


@pytest.mark.parametrize("key, value, what", [
    ("optimizer.population", "1000000000000", "optimizer.population: must be <= 1,000,000"),
    ("optimizer.generations", "1000000000000", "optimizer.generations: must be <= 1,000,000"),
    ("objective.dim", "1000000000", "objective.dim"),
    ("output", '"runs\\0x"', "NUL byte"),
])
def test_sizes_and_nul_bytes_are_refused_before_anything_is_allocated(tmp_path, key, value, what):
    job = tmp_path / "job.yaml"
    text = yaml.safe_dump(sphere_job(tmp_path, 'u'))
    job.write_text(text)
    if key == "output":
        lines = [ln for ln in text.splitlines() if not ln.startswith("output:")]
        job.write_text("\n".join([*lines, f"output: {value}"]) + "\n")
        one_error(tuner("run", job), what)
    else:
        one_error(tuner("run", job, "--set", f"{key}={value}"), what)
    assert not (tmp_path / "runs").exists()


@pytest.mark.slow
def test_a_huge_error_message_is_stored_cut_and_the_history_stays_readable(tmp_path):
    job = failing_python_job(tmp_path, "loud_u", "ValueError('y' * 200_000)", "u")
    env = {**os.environ, "PYTHONPATH": str(tmp_path)}
    out = tuner("run", job, "--run-dir", tmp_path / "r", "-q", "--no-report", env=env)
    assert out.returncode == 1 and "Traceback" not in out.stderr, out.stderr  # every evaluation failed
    assert "200,027 characters, cut to 4,000" in (tmp_path / "r" / "history.csv").read_text()  # length noted
    for cmd in (["show", tmp_path / "r"], ["report", tmp_path / "r"]):
        r = tuner(*cmd, env=env)
        assert r.returncode in (0, 2) and "Traceback" not in r.stderr, r.stderr
