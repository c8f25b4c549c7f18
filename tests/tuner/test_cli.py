"""The command line: clear config errors with exit status 2, and the happy path."""

import json

import pytest
import yaml

from tests.conftest import run_tuner

GOOD = {"name": "c", "seed": 1, "objective": {"kind": "function", "function": "sphere", "dim": 2},
        "optimizer": {"method": "pso", "population": 4, "generations": 2}, "parallel": {"backend": "serial"}}


def tuner(*args, cwd=None):
    return run_tuner(*args, cwd=cwd)


def write(tmp_path, cfg, name="job.yaml"):
    p = tmp_path / name
    p.write_text(yaml.safe_dump(cfg) if isinstance(cfg, dict) else cfg)
    return p


def merged(**over):
    cfg = json.loads(json.dumps(GOOD))
    for k, v in over.items():
        if isinstance(v, dict) and isinstance(cfg.get(k), dict):
            cfg[k].update(v)
        else:
            cfg[k] = v
    return cfg


@pytest.mark.parametrize("cfg, expected", [
    (merged(optimiser={"method": "pso"}), ["optimiser", "unknown key", "allowed top-level keys"]),
    (merged(seed="seven"), ["seed", "expected int", "'seven'"]),
    (merged(parameters={"x0": {"low": 1.0, "high": 1.0}}), ["parameters.x0", "low < high", "low=1.0"]),
    (merged(parameters={"x0": {"low": 0.0, "high": 1.0, "scale": "log"}}),
     ["parameters.x0", "log scale needs low > 0", "low=0.0"]),
    (merged(optimizer={"method": "sgd"}), ["optimizer.method", "'sgd'", "cmaes", "pso"]),
    (merged(optimizer={"inertia_typo": 1}), ["optimizer.inertia_typo", "unknown option", "inertia"]),
    (merged(parallel={"backend": "mpi"}), ["parallel.backend", "'mpi'", "loky"]),
    (merged(objective={"function": "himmelblau"}), ["objective.function", "'himmelblau'", "rosenbrock"]),
    (merged(objective={"kind": "telepathy"}), ["objective.kind", "'telepathy'", "closed_loop"]),
    ("objective: [unclosed", ["not valid YAML"]),
])
def test_bad_config_names_file_key_value_and_allowed(tmp_path, cfg, expected):
    p = write(tmp_path, cfg)
    out = tuner("run", str(p))
    assert out.returncode == 2, out.stderr
    assert "Traceback" not in out.stderr
    assert str(p) in out.stderr
    for text in expected:
        assert text in out.stderr, (text, out.stderr)


def test_missing_config_file(tmp_path):
    out = tuner("run", str(tmp_path / "nope.yaml"))
    assert out.returncode == 2 and "nope.yaml: file not found" in out.stderr and "Traceback" not in out.stderr


def test_missing_data_file_in_objective(tmp_path):
    cfg = merged()
    cfg["objective"] = {"kind": "filter", "filter": "madgwick", "data": [{"csv": {"path": "missing.csv"}}]}
    out = tuner("run", str(write(tmp_path, cfg)))
    assert out.returncode == 2, out.stderr
    assert "missing.csv" in out.stderr and "Traceback" not in out.stderr


@pytest.mark.slow
def test_set_overrides_and_outputs(tmp_path):
    p = write(tmp_path, merged(output=str(tmp_path / "runs")))
    out = tuner("run", str(p), "--set", "optimizer.generations=3", "--seed", "5", "-q", "--no-report")
    assert out.returncode == 0, out.stderr
    run_dir = out.stdout.split("run directory: ")[1].split()[0]
    meta = json.loads(open(f"{run_dir}/meta.json").read())
    assert meta["seed"] == 5 and meta["generations"] == 3
    show = tuner("show", run_dir)
    assert show.returncode == 0 and "best:" in show.stdout
    exp = tuner("export", run_dir, "--format", "json")
    assert json.loads(exp.stdout)["params"].keys() == {"x0", "x1"}
    lst = tuner("list")
    assert "pso" in lst.stdout and "cmaes" in lst.stdout and "rosenbrock" in lst.stdout
    assert tuner("--help").stdout.count("tuner run") >= 1


@pytest.mark.slow
def test_progress_lines(tmp_path):
    out = tuner("run", str(write(tmp_path, merged(output=str(tmp_path / "runs")))), "--no-report")
    assert "gen 1/2  best" in out.stderr and "eval/s" in out.stderr and "ETA" in out.stderr


def test_a_max_evals_budget_shows_evaluations_done_of_total_with_an_eta(tmp_path):
    """Without generations the budget is max_evals: the progress line counts evaluations against it and gives
    an ETA (it said gen 27/? and none)."""
    cfg = merged(output=str(tmp_path / "runs"))
    cfg["optimizer"] = {"method": "pso", "population": 4, "max_evals": 12}
    out = tuner("run", str(write(tmp_path, cfg)), "--no-report")
    lines = [x for x in out.stderr.splitlines() if x.startswith("gen ")]
    assert [x.split("  ")[1] for x in lines] == ["evals 4/12", "evals 8/12", "evals 12/12"], lines
    assert all("ETA" in x and "/?" not in x for x in lines)
    assert lines[-1].split("ETA ")[1].startswith("0:00:00")
