"""Bad input and faults end in one `error:` line and exit 2 (or recorded failures), never a traceback."""

import csv
import errno
import functools
import subprocess
import sys

import pytest
import yaml

from tests.conftest import one_error_line, run_tuner

BASE = {"name": "e", "seed": 1, "objective": {"kind": "function", "function": "sphere", "dim": 2},
        "optimizer": {"method": "pso", "population": 4, "generations": 2}, "parallel": {"backend": "serial"}}


tuner = functools.partial(run_tuner, timeout=180)


@pytest.mark.parametrize("sets, expected", [
    (["optimizer.method=cmaes", "optimizer.population=1"], ["optimizer.population", "cmaes", "in [2, inf)",
                                                            "got 1"]),
    (["optimizer.method=de", "optimizer.population=2"], ["optimizer.population", "de", "in [4, inf)", "got 2"]),
    (["optimizer.method=de", "optimizer.population=3"], ["optimizer.population", "got 3"]),
    (["optimizer.inertia=bogus"], ["optimizer.inertia", "'bogus'", "['constant', 'linear']"]),
    (["optimizer.c1=abc"], ["optimizer.c1", "must be a number in [0, inf)", "got 'abc'"]),
    (["optimizer.constriction=true"], ["optimizer.constriction", "c1 + c2 > 4", "got 2.0"]),
    (["optimizer.method=cmaes", "optimizer.cma_options=3"], ["optimizer.cma_options", "mapping", "got 3"]),
    (["optimizer.method=cmaes_restart", "optimizer.cma_options={tolx: 1e-3, bogus: 1}"],
     ["optimizer.cma_options", "not pycma options: ['bogus']"]),
    (["optimizer.no_such_option=1"], ["optimizer.no_such_option", "unknown option for pso", "inertia"]),
    # rules that need the number of free parameters: checked once the space is known, with the same line
    (["objective.dim=1", "optimizer.method=cmaes"], ["optimizer:", "invalid for cmaes", "at least 2 free parameters"]),
    (["optimizer.method=trust_region", "optimizer.n_init=7"], ["optimizer.n_init", "multiple of the population 4",
                                                              "got 7"]),
])
def test_invalid_optimizer_options_fail_before_the_run_directory(tmp_path, sets, expected):
    p = tmp_path / "job.yaml"
    p.write_text(yaml.safe_dump({**BASE, "output": str(tmp_path / "runs")}))
    out = tuner("run", str(p), *[x for s in sets for x in ("--set", s)])
    one_error_line(out, str(p), *expected)
    assert not (tmp_path / "runs").exists()


def test_config_path_that_is_a_directory_or_binary(tmp_path):
    one_error_line(tuner("run", str(tmp_path)), str(tmp_path), "is a directory")
    b = tmp_path / "bin.yaml"
    b.write_bytes(bytes(range(256)) * 4)
    one_error_line(tuner("run", str(b)), str(b), "not a text file")
    z = tmp_path / "nul.yaml"
    z.write_bytes(b"name: x\x00\x00\n")
    one_error_line(tuner("run", str(z)), str(z), "binary file")


@pytest.mark.parametrize("sweep, expected", [
    ({"name": "../../x", "base": "job.yaml"}, ["sweep.name", "'../../x'"]),
    ({"name": "a/b", "base": "job.yaml"}, ["sweep.name", "plain directory name"]),
    ({"name": "ok", "base": "job.yaml", "variants": {"a": [1, 2]}}, ["sweep.variants.a", "got list"]),
    ({"name": "ok", "base": "job.yaml", "variants": {"..": {"seed": 2}}}, ["sweep.variants...", "plain names"]),
])
def test_sweep_names_and_variants(tmp_path, sweep, expected):
    (tmp_path / "job.yaml").write_text(yaml.safe_dump(BASE))
    p = tmp_path / "sw.yaml"
    p.write_text(yaml.safe_dump({"sweep": sweep}))
    one_error_line(tuner("sweep", str(p), cwd=tmp_path), *expected)
    assert not (tmp_path / "runs").exists() and not (tmp_path.parent / "x").exists()


@pytest.mark.parametrize("data, expected", [
    ({"data": [{"synthetic": {"generator": "nosuch", "duration_s": 3}}]}, ["unknown synthetic generator 'nosuch'"]),
    ({"data": [{"synthetic": {"generator": "bench6dof", "duration_s": -3}}]}, ["duration_s", "got -3"]),
    ({"data": [{"csv": {"path": "missing.csv"}}]}, ["missing.csv"]),
])
@pytest.mark.slow
def test_evaluate_with_bad_data(tmp_path, data, expected):
    job = {**BASE, "objective": {"kind": "filter", "filter": "madgwick",
                                 "data": [{"synthetic": {"generator": "bench6dof", "duration_s": 3, "seed": 1}}]}}
    (tmp_path / "job.yaml").write_text(yaml.safe_dump(job))
    (tmp_path / "d.yaml").write_text(yaml.safe_dump(data))
    one_error_line(tuner("evaluate", str(tmp_path / "job.yaml"), "--data", str(tmp_path / "d.yaml")),
                   str(tmp_path / "d.yaml"), *expected)


def test_run_dir_that_cannot_be_created(tmp_path):
    (tmp_path / "afile").write_text("x")
    p = tmp_path / "job.yaml"
    p.write_text(yaml.safe_dump(BASE))
    one_error_line(tuner("run", str(p), "--run-dir", str(tmp_path / "afile" / "run")), "afile")


def test_full_disk_is_one_error_line_and_the_run_resumes(tmp_path, monkeypatch, capsys):
    """ENOSPC at the k-th write: one error line naming the file; what was written stays, resume finishes."""
    from tuner import cli, rundir

    p = tmp_path / "job.yaml"
    p.write_text(yaml.safe_dump({**BASE, "optimizer": {"method": "pso", "population": 4, "generations": 4}}))
    real, calls = rundir.atomic_write, []

    def failing(path, data):
        calls.append(path)
        if len(calls) == 9:  # a few generations in
            raise OSError(errno.ENOSPC, "No space left on device", str(path))
        return real(path, data)

    monkeypatch.setattr(rundir, "atomic_write", failing)
    rd = tmp_path / "run"
    assert cli.main(["run", str(p), "--run-dir", str(rd), "-q", "--no-report"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith(f"error: {calls[-1]}: No space left on device"), err
    rows_before = len(list(csv.DictReader(open(rd / "history.csv"))))
    assert rows_before >= 4
    monkeypatch.setattr(rundir, "atomic_write", real)
    assert cli.main(["resume", str(rd), "-q", "--no-report"]) == 0
    ref = tmp_path / "ref"
    assert cli.main(["run", str(p), "--run-dir", str(ref), "-q", "--no-report"]) == 0
    a = [r["fitness"] for r in csv.DictReader(open(rd / "history.csv"))]
    b = [r["fitness"] for r in csv.DictReader(open(ref / "history.csv"))]
    assert a == b and len(a) == 16


def test_list_into_a_closed_pipe_prints_no_traceback():
    out = subprocess.run(f"{sys.executable} -m tuner list | head -1", shell=True, capture_output=True, text=True,
                         timeout=120)
    assert out.stdout.strip() == "optimizers:" and "Traceback" not in out.stderr and out.stderr == ""
    proc = subprocess.Popen([sys.executable, "-m", "tuner", "list"], stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    proc.stdout.close()  # closed before the first write
    err = proc.stderr.read().decode()
    assert proc.wait(timeout=120) == 0 and "Traceback" not in err and "BrokenPipe" not in err


@pytest.mark.slow
def test_list_sections_come_from_the_registry():
    out = tuner("list", "filters")
    assert out.returncode == 0 and "filters (objective.kind: filter):" in out.stdout and "madgwick" in out.stdout
    assert "optimizers" not in out.stdout
    one_error_line(tuner("list", "gadgets"), "unknown section 'gadgets'", "controllers", "filters", "functions")


def _error_types():
    from objectives.attitude.data.recording import RecordingError
    from tuner.config import ConfigError
    from tuner.optimizers.base import OptionError
    from tuner.registry import RegistryError
    from tuner.rundir import RunError
    from tuner.space import SpaceError

    return [ConfigError("job.yaml", "optimizer.population", "must be >= 2"), ConfigError(None, "", "no key"),
            OptionError("must be a number", key="optimizer.c1"), RegistryError("unknown kind 'x'"),
            RunError("runs/r: in use by pid 1"), SpaceError("parameters.x: low >= high"),
            RecordingError("a.csv: column 'time' missing")]


@pytest.mark.parametrize("exc", _error_types(), ids=lambda e: type(e).__name__)
def test_errors_survive_pickling_from_a_worker_process(exc):
    """A job of a parallel sweep runs in a worker process: an error raised there is pickled to the parent,
    which prints its one line. An exception whose __init__ takes other arguments than ``args`` would not
    unpickle, and the sweep would end in a BrokenProcessPool traceback instead."""
    import pickle

    back = pickle.loads(pickle.dumps(exc))
    assert type(back) is type(exc) and str(back) == str(exc)
    assert vars(back) == vars(exc)
