"""The engine stands alone: no import of `objectives` under tuner/, a registry fed by entry points,
and the declared hooks of tuner.objective used by the domain objectives."""

import ast
import json
import math
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest
import yaml

from tuner.objective import HOOKS, Score, TunableObjective, hook
from tuner.python_objective import PythonObjective
from tuner.registry import REGISTRY, Registry, RegistryError

TUNER = Path(__file__).resolve().parents[2] / "tuner"


def test_no_module_of_tuner_imports_objectives():
    offenders = []
    for path in sorted(TUNER.rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text(), str(path))):
            names = []
            if isinstance(node, ast.Import):
                names = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom) and node.level == 0:
                names = [node.module or ""]
            elif isinstance(node, ast.Call) and getattr(node.func, "attr", getattr(node.func, "id", "")) in (
                    "import_module", "__import__") and node.args and isinstance(node.args[0], ast.Constant):
                names = [str(node.args[0].value)]
            offenders += [f"{path.name}:{node.lineno} {n}" for n in names if n.split(".")[0] == "objectives"]
    assert not offenders, offenders


def _blocked_python(tmp_path, code):
    """Run code in a fresh interpreter where `import objectives` raises ImportError."""
    prog = "import sys\nsys.modules['objectives'] = None\n" + textwrap.dedent(code)
    return subprocess.run([sys.executable, "-c", prog], capture_output=True, text=True, cwd=tmp_path,
                          timeout=180, env={"PYTHONPATH": str(tmp_path), "PATH": "/usr/bin:/bin",
                                            "NUMBA_CACHE_DIR": str(tmp_path / "numba")})


@pytest.mark.slow
def test_every_tuner_module_imports_and_a_python_objective_runs_without_objectives(tmp_path):
    (tmp_path / "userobj.py").write_text("def f(p):\n    return (p['a'] - 1.0) ** 2\n")
    cfg = {"name": "u", "objective": {"kind": "python", "callable": "userobj:f"},
           "parameters": {"a": {"low": -2.0, "high": 3.0}}, "optimizer": {"method": "pso", "population": 6,
                                                                         "generations": 3},
           "parallel": {"backend": "serial"}, "output": str(tmp_path / "runs")}
    (tmp_path / "job.yaml").write_text(yaml.safe_dump(cfg))
    out = _blocked_python(tmp_path, """
        import importlib, pkgutil, tuner
        for m in pkgutil.walk_packages(tuner.__path__, "tuner."):
            if m.name != "tuner.__main__":  # runs the CLI
                importlib.import_module(m.name)
        from tuner.cli import main
        assert main(["run", "job.yaml", "-q"]) == 0
        try:
            import objectives
        except ImportError:
            print("objectives blocked")
    """)
    assert out.returncode == 0, out.stderr
    assert "objectives blocked" in out.stdout and "best fitness" in out.stdout


def test_domain_kinds_come_from_entry_points():
    kinds = REGISTRY.kinds()
    assert {"filter", "closed_loop", "function", "python"} <= set(kinds)
    assert "objectives.attitude.objective:FilterObjective" in kinds["filter"]
    cat = REGISTRY.catalog()
    assert cat["filters"][0] == "filter" and "madgwick" in cat["filters"][1]
    assert cat["controllers"][0] == "closed_loop" and "pid" in cat["controllers"][1]
    assert cat["functions"] == ("function", ["ackley", "rastrigin", "rosenbrock", "sphere"])


def test_a_name_registered_twice_is_refused_naming_both():
    r = Registry(group="tuner.no-such-group")
    r.register("mine", PythonObjective, "pkg-a")
    with pytest.raises(RegistryError, match="'mine' is registered twice: by pkg-a and by pkg-b"):
        r.register("mine", PythonObjective, "pkg-b")
    with pytest.raises(RegistryError, match="unknown kind 'other'.*no domain package registered"):
        Registry(group="tuner.no-such-group").get("other")


def test_broken_entry_point_is_an_error_naming_it():
    r = Registry(group="tuner.no-such-group")
    r.register("ghost", "no_such_module_xyz:Obj", "ghost-pkg")
    with pytest.raises(RegistryError, match="registered by ghost-pkg but does not import"):
        r.get("ghost")


def test_hook_and_protocol():
    assert set(HOOKS) <= set(dir(TunableObjective))

    def bare(p):
        return 1.0

    assert all(hook(bare, h) is None for h in HOOKS)
    with pytest.raises(ValueError, match="unknown objective hook"):
        hook(bare, "score_it")
    s = Score(1.5, {"r": {"m": 2.0}})
    assert s.ok and not Score(1.0, failed="diverged").ok
    with pytest.raises(AttributeError):
        s.fitness = 2.0


def test_filter_objective_score_is_typed_and_matches_call():
    from objectives.attitude.objective import FilterObjective

    obj = FilterObjective.from_config({"kind": "filter", "filter": "madgwick", "data": [
        {"synthetic": {"generator": "bench6dof", "duration_s": 4, "seed": 1}}]})
    p = obj.default_params()
    s = obj.score(p)
    assert isinstance(s, Score) and not s.failed and not obj.has_test_data
    assert obj(p).fitness == s.fitness and math.isfinite(s.fitness)
    assert "beta" in obj.parameter_names()
    assert obj.describe()["objective"] == {"kind": "filter", "filter": "madgwick", "metric": "euler_mse_geomean"}


def test_export_takes_provenance_and_tables_from_the_objective(tmp_path):
    from tuner.config import config_from_dict
    from tuner.export import export
    from tuner.run import run as run_job

    cfg = config_from_dict({"name": "exp", "seed": 3, "objective": {"kind": "function", "function": "ackley",
                                                                      "dim": 2},
                            "optimizer": {"method": "random", "population": 5, "generations": 2},
                            "parallel": {"backend": "serial", "n_jobs": 1}},
                           source=str(tmp_path / "job.yaml"), base_dir=tmp_path)
    res = run_job(cfg, run_dir=tmp_path / "r", quiet=True, report=False)
    run = res.run_dir
    doc = json.loads(export(run, "json"))
    assert doc["objective"] == {"kind": "function", "function": "ackley"} and doc["data"] is None
    assert doc["params"] == res.best_params and doc["fitness"] == res.best_fitness
    cfg_doc = yaml.safe_load((run / "config.yaml").read_text())
    cfg_doc["objective"] = {"kind": "python", "callable": "nomod:f"}
    (run / "config.yaml").write_text(yaml.safe_dump(cfg_doc))
    doc = json.loads(export(run, "json"))  # no longer builds: kind and parameters only
    assert doc["objective"] == {"kind": "python"} and doc["params"] == res.best_params
