"""Without the optional mujoco package: every module of the MuJoCo unit imports, the registry lists the kind, and a
MuJoCo job is one `error:` line saying how to install it (runs whether mujoco is installed or not)."""

import subprocess
import sys
import textwrap
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def test_the_unit_needs_no_mujoco_until_a_model_is_built(tmp_path):
    job = tmp_path / "job.yaml"
    job.write_text("name: m\nobjective: {kind: closed_loop, plant: {mujoco: model.xml}, controller: joint_pid, "
                   "scenario: {duration_s: 1}}\noptimizer: {method: random, population: 2, generations: 1}\n")
    code = textwrap.dedent(f"""
        import importlib, pkgutil, sys
        sys.modules["mujoco"] = None  # import mujoco raises ImportError
        import objectives.control.plants.mujoco as unit
        for m in pkgutil.walk_packages(unit.__path__, unit.__name__ + "."):
            importlib.import_module(m.name)
        from objectives.control.plants import plant_kind
        assert plant_kind({{"mujoco": "model.xml"}}).family == "mujoco"
        from tuner.cli import main
        assert main(["describe", "plant"]) == 0
        sys.exit(main(["run", {str(job)!r}]))
    """)
    res = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert res.returncode == 2, res.stderr
    assert "mujoco" in res.stdout
    err = res.stderr.strip().splitlines()
    assert err == [f"error: {job}: objective.plant.mujoco: MuJoCo plants need the mujoco package "
                   "(pip install -e '.[mujoco]')"], res.stderr
