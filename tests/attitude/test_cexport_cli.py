"""`tuner export --format c-filter` and `tuner verify-c` on finished runs: the README's firmware example compiled
against an export, the exported configuration equal to the run's deployment, verify-c's metrics equal for C and
model, and one error line without a compiler. The slow tests use configs/broad_ekf.yaml and
configs/broad_madgwick.yaml with tiny budgets."""

from __future__ import annotations

import os
import re
import subprocess
from pathlib import Path

import pytest
import yaml

from objectives.attitude.cexport.build import STRICT_FLAGS, find_compiler
from objectives.attitude.data.broad import default_broad_dir
from tests.attitude.cexport_cases import needs_cc
from tests.conftest import readme_c_block, run_tuner

ROOT = Path(__file__).resolve().parents[2]
ENV = {**os.environ, "NUMBA_CACHE_DIR": str(ROOT / ".cache" / "numba")}


def _tuner(*args, env=None, check=True):
    return run_tuner(*args, cwd=ROOT, env=env, check=check)  # in this process unless an environment is given


def _run(tmp: Path, config: Path, *sets: str) -> Path:
    """A tiny run of ``config``; no test here reads its report."""
    run_dir = tmp / "run"
    _tuner("run", config, "--run-dir", run_dir, "-q", "--no-report", "--set", "optimizer.population=2", "--set",
           "optimizer.generations=1", "--set", "parallel.backend=serial", *sum((["--set", s] for s in sets), []))
    return run_dir


@pytest.fixture(scope="module")
def bench_run(tmp_path_factory):
    """A tiny EKF run on the bench with non-default fixed options (robust blocks, Huber, gate, current gyro)."""
    tmp = tmp_path_factory.mktemp("cli")
    cfg = {"name": "c-export", "seed": 3, "objective": {
        "kind": "filter", "filter": "ekf", "warmup_s": 1.0,
        "fixed": {"p0_b": 1.0e-4, "gyro_sample": "current", "huber_deg": 5.0, "acc_gate": 0.3,
                  "mag_rejection": True, "rest_bias": True, "acc_lp_tau_s": 3.0},
        "data": [{"synthetic": {"generator": "bench6dof", "duration_s": 8.0, "rate_hz": 200.0, "seed": 1}}]},
        "parameters": {"rho": {"low": 0.3, "high": 30.0, "scale": "log"}}}
    (tmp / "c.yaml").write_text(yaml.safe_dump(cfg))
    return _run(tmp, tmp / "c.yaml")


@needs_cc
def test_export_compiles_with_the_readme_example(bench_run, tmp_path):
    out = _tuner("export", bench_run, "--format", "c-filter", "--prefix", "EKF1", "--out", tmp_path)
    assert "ekf1.h" in out.stderr and "ekf1.c" in out.stderr
    header = (tmp_path / "ekf1.h").read_text()
    best = yaml.safe_load((bench_run / "best.yaml").read_text())
    assert bench_run.name in header and "200 Hz" in header and repr(best["fitness"]) in header
    assert f"rho: {best['params']['rho']!r}" in header  # the searched value, exactly
    for key in ("huber_deg: 5.0", "acc_gate: 0.3", "gyro_sample: 'current'", "mag_rejection: True"):
        assert key in header  # the fixed values
    (tmp_path / "main.c").write_text(readme_c_block("firmware-example"))
    exe = tmp_path / "main"
    res = subprocess.run([*find_compiler(), *STRICT_FLAGS, "-O2", "-o", str(exe), str(tmp_path / "main.c"),
                          str(tmp_path / "ekf1.c"), "-lm"], capture_output=True, text=True)
    assert res.returncode == 0 and not res.stderr, res.stderr
    q = [float(x) for x in subprocess.run([str(exe)], capture_output=True, text=True, check=True).stdout.split()]
    assert len(q) == 4 and abs(sum(x * x for x in q) - 1.0) < 1e-6
    _tuner("export", bench_run, "--format", "c-filter", "--precision", "float", "--out", tmp_path / "f")
    assert "typedef float" in next((tmp_path / "f").glob("*.h")).read_text()


def _verify(run_dir, *extra):
    out = _tuner("verify-c", run_dir, *extra)
    m = re.search(r"fitness model (\S+), C (\S+) \(C - model (\S+)\)", out.stdout)
    assert m, out.stdout
    return float(m.group(1)), float(m.group(2)), out.stdout


@needs_cc
def test_verify_c_prints_equal_metrics(bench_run):
    py, c, text = _verify(bench_run)
    assert abs(py - c) < 1e-9 * max(1.0, abs(py))
    assert re.search(r"max angle (\S+) rad", text) and float(re.search(r"max angle (\S+) rad", text).group(1)) < 1e-9
    py_f, c_f, _ = _verify(bench_run, "--precision", "float")
    assert py_f == py and abs(c_f - py) < 0.01


@needs_cc
def test_verify_c_on_other_data(bench_run, tmp_path):
    """--data: recordings the run never saw (another seed and rate of the bench, the EKF's per-sample values
    as tuned): the model and its C still score alike, each recording named in the output."""
    data = {"data": [{"synthetic": {"generator": "bench6dof", "duration_s": 6.0, "rate_hz": 200.0, "seed": s}}
                     for s in (7, 8)]}
    (tmp_path / "d.yaml").write_text(yaml.safe_dump(data))
    py, c, text = _verify(bench_run, "--data", tmp_path / "d.yaml", "--fast-math")
    assert abs(py - c) < 1e-9 * max(1.0, abs(py)) and text.count(" max angle ") == 2, text
    assert "-ffast-math" in text


@needs_cc
def test_verify_c_on_a_tilt_kf_run(tmp_path):
    """The thesis's fuzzy-adaptive tilt KF (mse_1d, thesis eq. 3.18) on the tilt bench: the C scores what the
    model scores."""
    cfg = {"name": "akf1d", "objective": {"kind": "filter", "filter": "akf1d", "metric": "mse_1d", "fixed":
                                          {"p0_theta": 1.0e-3}, "data": [
        {"synthetic": {"generator": "tilt1d", "duration_s": 6.0, "rate_hz": 400.0, "seed": 2}}]}}
    (tmp_path / "c.yaml").write_text(yaml.safe_dump(cfg))
    py, c, text = _verify(_run(tmp_path, tmp_path / "c.yaml"))
    assert abs(py - c) < 1e-9 * max(1.0, abs(py)), text


def test_verify_c_without_a_compiler_is_one_error_line(bench_run, tmp_path):
    env = {**ENV, "PATH": str(tmp_path), "CC": ""}
    out = _tuner("verify-c", bench_run, env=env, check=False)
    assert out.returncode == 2
    lines = out.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error:") and "compiler" in lines[0], out.stderr


def _one_error(out, *fragments):
    assert out.returncode == 2 and "Traceback" not in out.stderr, (out.returncode, out.stderr)
    lines = out.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: "), out.stderr
    for f in fragments:
        assert f in lines[0], (f, lines[0])


@needs_cc
def test_verify_c_with_a_failing_or_chattering_compiler_is_one_error_line(bench_run, tmp_path, monkeypatch):
    """CC=/bin/false fails without a word; a compiler that writes only to stderr (exit 0) is refused too: the
    generated C must compile without a warning. Each is one error line naming the compiler, not a traceback."""
    chatty = tmp_path / "chatty-cc"
    chatty.write_text("#!/bin/sh\necho 'warning: something odd' >&2\nexit 0\n")
    chatty.chmod(0o755)
    for cc, what in (("/bin/false", "/bin/false failed (exit status 1)"), (str(chatty), "wrote to stderr")):
        monkeypatch.setenv("CC", cc)
        _one_error(_tuner("verify-c", bench_run, check=False), "C compiler", what)


@needs_cc
def test_verify_c_parses_cc_as_make_does_and_names_the_compiler(bench_run, monkeypatch):
    """CC with flags keeps them (it was replaced by cc); a CC that is not found is an error naming it; the
    output says which compiler ran."""
    cc = find_compiler()[0]
    monkeypatch.setenv("CC", f"{cc} -DTUNER_VERIFY_FLAG=1")
    out = _tuner("verify-c", bench_run)
    assert f"compiled with {cc} -DTUNER_VERIFY_FLAG=1 " in out.stdout, out.stdout
    monkeypatch.setenv("CC", "no-such-compiler-xyz -O1")
    _one_error(_tuner("verify-c", bench_run, check=False), "CC='no-such-compiler-xyz -O1'", "not found")
    monkeypatch.setenv("CC", "")  # set but empty: ignored, as make ignores it
    assert "fitness model " in _tuner("verify-c", bench_run).stdout


@needs_cc
def test_verify_c_labels_both_numbers_and_refuses_data_without_recordings(bench_run, tmp_path):
    out = _tuner("verify-c", bench_run)
    assert re.search(r"fitness model \S+, C \S+ \(C - model \S+\)", out.stdout), out.stdout
    assert re.search(r"model \S+ C \S+ \(", out.stdout.splitlines()[1]), out.stdout  # per recording, labelled
    (tmp_path / "none.yaml").write_text("data: []\n")
    _one_error(_tuner("verify-c", bench_run, "--data", tmp_path / "none.yaml", check=False),
               "none.yaml", "no recordings")


def test_export_refuses_a_filter_without_a_c_port(tmp_path):
    cfg = {"name": "qukf", "objective": {"kind": "filter", "filter": "qukf", "data": [
        {"synthetic": {"generator": "bench6dof", "duration_s": 4.0, "rate_hz": 100.0, "seed": 1}}]}}
    (tmp_path / "c.yaml").write_text(yaml.safe_dump(cfg))
    run_dir = _run(tmp_path, tmp_path / "c.yaml")
    out = _tuner("export", run_dir, "--format", "c-filter", "--out", tmp_path / "x", check=False)
    assert out.returncode == 2 and out.stderr.startswith("error:") and "no C port" in out.stderr


@needs_cc
@pytest.mark.slow
@pytest.mark.broad
@pytest.mark.parametrize("config", ["broad_ekf.yaml", "broad_madgwick.yaml"])
def test_verify_c_on_the_broad_configs(config, tmp_path):
    if not (default_broad_dir() / "trials.json").exists():
        pytest.skip("BROAD data not found")
    run_dir = _run(tmp_path, ROOT / "configs" / config)
    py, c, text = _verify(run_dir)
    assert abs(py - c) < 1e-6, text
    assert text.count(" max angle ") == 16
