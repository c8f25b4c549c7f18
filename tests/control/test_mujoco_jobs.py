"""MuJoCo plants from YAML: the three examples tune, report and export from their folder; bad input is one
`error:` line with exit 2 before any tuning, listing the model's names. Skipped without mujoco."""

import shutil
from pathlib import Path

import pytest
import yaml

from tests.conftest import refused_job

pytest.importorskip("mujoco")

from tuner.cli import main  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]
EXAMPLES = ROOT / "configs" / "examples"


def _job(tmp_path, objective, name="bad"):
    shutil.copytree(EXAMPLES / "mujoco", tmp_path / "mujoco", dirs_exist_ok=True)
    (tmp_path / "broken.xml").write_text("<mujoco><worldbody><body><joint type='sideways'/></body></worldbody>"
                                         "</mujoco>")
    (tmp_path / "exploding.xml").write_text(
        "<mujoco><option timestep='0.05'/><worldbody><body><joint name='j' type='slide' axis='1 0 0' "
        "stiffness='1e9'/><geom size='0.1' mass='1e-6'/></body></worldbody><actuator><motor joint='j'/></actuator>"
        "<keyframe><key name='off' qpos='0.1'/></keyframe></mujoco>")
    obj = {"kind": "closed_loop", "controller": "joint_pid", "period_s": 0.002, "scenario": {"duration_s": 0.5},
           **objective}
    cfg = {"name": name, "seed": 1, "objective": obj, "optimizer": {"method": "random", "population": 4,
                                                                    "generations": 1},
           "parallel": {"backend": "serial"}, "output": str(tmp_path / "runs")}
    p = tmp_path / f"{name}.yaml"
    p.write_text(yaml.safe_dump(cfg))
    return p


CART = "mujoco/cartpole.xml"
BAD = {
    "missing file": ({"plant": {"mujoco": "nowhere.xml"}}, "objective.plant.mujoco: no such file"),
    "malformed model": ({"plant": {"mujoco": "broken.xml"}},
                        "objective.plant.mujoco: broken.xml does not compile: XML Error: invalid keyword: 'sideways'"),
    "unknown actuator": ({"plant": {"mujoco": CART, "actuators": ["shove"]}},
                         "objective.plant.actuators: no actuator named 'shove' in the model; its actuators: ['push']"),
    "unknown sensor": ({"plant": {"mujoco": CART, "outputs": [{"sensor": "imu"}]}},
                       "objective.plant.outputs[0].sensor: no sensor named 'imu' in the model; its sensors: "
                       "['cart_position', 'pole_angle']"),
    "unknown output": ({"plant": {"mujoco": CART, "outputs": ["tip"]}},
                       "objective.plant.outputs[0]: 'tip' is neither a joint nor a sensor of the model; joints: "
                       "['slider', 'hinge'], sensors: ['cart_position', 'pole_angle']"),
    "unknown keyframe": ({"plant": {"mujoco": CART, "keyframe": "down"}},
                         "objective.plant.keyframe: no keyframe named 'down' in the model; its keyframes: ['upright']"),
    "period not a multiple": ({"plant": {"mujoco": CART}, "period_s": 0.005},
                              "objective.period_s: 0.005 s is not a whole number of the model's timestep 0.002 s "
                              "(cartpole.xml); use a multiple, e.g. 0.004 or 0.006"),
    "unstable model": ({"plant": {"mujoco": "exploding.xml", "keyframe": "off"}, "period_s": 0.05},
                       "objective.plant.mujoco: exploding.xml is unstable at its operating point within one period"),
    "unknown parameter": ({"plant": {"mujoco": CART, "parameters": {"body.pole.weight": 1.0}}},
                          "objective.plant.parameters.body.pole.weight: not a named parameter of this model"),
    "uncertain unknown": ({"plant": {"mujoco": CART}, "controller": "lqr_fd",
                           "uncertainty": {"parameters": {"body.wheel.mass": {"rel": 0.1}}}},
                          "objective.uncertainty.parameters.body.wheel.mass: not a parameter of this plant"),
    "pid without loops": ({"plant": {"mujoco": CART, "outputs": [{"body": "pole", "angle": "pitch"}],
                                     "loops": []}},
                          "objective.plant.loops: expected a list of [output, actuator] pairs"),
    "reference of no output": ({"plant": {"mujoco": CART}, "scenario": {"duration_s": 1.0,
                                                                        "reference": {"pole": [{"t": 0, "value": 1}]}}},
                               "objective.scenario.reference.pole: not an output of the plant; outputs: "
                               "['slider', 'hinge']"),
    "margin requirement": ({"plant": {"mujoco": CART}, "requirements": {"max_ms": 1.4}},
                           "objective.requirements.max_ms: not measured on a MuJoCo plant (no load input, no "
                           "linear loop)"),
    "pendulum controller": ({"plant": {"mujoco": CART}, "controller": "pid2dof"},
                            "objective.controller: unknown controller 'pid2dof' for this plant"),
    "unknown plant key": ({"plant": {"mujoco": CART, "x0": [0, 0]}},
                          "objective.plant.x0: unknown key; allowed: ['actuators', 'ctrl', 'ctrlrange', 'keyframe'"),
}


@pytest.mark.parametrize("case", sorted(BAD))
def test_bad_input_is_one_error_line(tmp_path, capsys, case):
    objective, expected = BAD[case]
    refused_job(_job(tmp_path, objective), capsys, expected)


@pytest.mark.slow
@pytest.mark.parametrize("name", ["mujoco_cartpole_lqr", "mujoco_dip_lqr", "mujoco_arm_pid"])
def test_example_tunes_reports_and_exports(tmp_path, capsys, name):
    """Each example from a copy of its folder, with a small budget and short horizons (held-out models too)."""
    src = yaml.safe_load((EXAMPLES / f"{name}.yaml").read_text())
    src["optimizer"].update(population=4, generations=2)
    src["output"] = str(tmp_path / "runs")
    if "requirements" in src["objective"]:  # 8 random candidates rarely meet them: one that any does
        src["objective"]["requirements"] = {"max_overshoot_pct": 100.0}
    unc = src["objective"].get("uncertainty")
    if unc:  # the double pendulum: 3 s of its 10 s, 4 of its 17 tuning models, 4 held-out models
        src["objective"]["scenario"]["duration_s"] = 3.0
        unc.update(tune={"corners": False, "samples": 1, "seed": 0}, validate={"samples": 4, "seed": 1})
        unc["parameters"] = dict(list(unc["parameters"].items())[:2])
    shutil.copytree(EXAMPLES / "mujoco", tmp_path / "mujoco")
    path = tmp_path / f"{name}.yaml"
    path.write_text(yaml.safe_dump(src))
    assert main(["run", str(path)]) == 0
    run = next((tmp_path / "runs").iterdir())
    best = yaml.safe_load((run / "best.yaml").read_text())
    assert best["fitness"] < 1e12
    assert (run / "figures" / "response.png").stat().st_size > 1000
    req = (run / "requirements.md").read_text()
    assert req.startswith("# Requirements") and (("| requirement |" in req) != (name == "mujoco_dip_lqr"))
    assert ("## Held-out models" in req) == bool(unc) and (run / "figures" / "held_out.png").exists() == bool(unc)
    assert (run / "report.md").exists() and "response" in (run / "report.md").read_text()
    capsys.readouterr()
    for fmt in ("yaml", "json", "python", "c"):
        assert main(["export", str(run), "--format", fmt]) == 0
        out = capsys.readouterr().out
        assert ("gains" in out.lower()) if name == "mujoco_arm_pid" else ("K" in out and "u_op" in out.lower())


@pytest.mark.slow
def test_same_seed_same_history_serial_threads_and_loky(tmp_path, monkeypatch):
    """The same job and seed give the same history whichever backend runs it (loky rebuilds the plant from the
    pickled spec in each worker)."""
    import numpy as np

    from tests.tuner.jobs import unrendered_figures
    from tuner.config import config_from_dict
    from tuner.run import run

    unrendered_figures(monkeypatch)
    src = yaml.safe_load((EXAMPLES / "mujoco_cartpole_lqr.yaml").read_text())
    src["optimizer"].update(population=6, generations=2)
    src["objective"]["scenario"]["duration_s"] = 4.0
    src["objective"]["uncertainty"] = {"parameters": {"body.pole.mass": {"rel": 0.2}},
                                       "tune": {"corners": False, "samples": 1}, "validate": {"samples": 1}}
    hist = []
    for i, par in enumerate(({"backend": "serial"}, {"backend": "threads", "n_jobs": 2},
                             {"backend": "loky", "n_jobs": 2})):
        src["output"] = str(tmp_path / f"runs{i}")
        src["parallel"] = par
        res = run(config_from_dict(src, base_dir=EXAMPLES), quiet=True, report=False)
        hist.append(np.loadtxt(Path(res.run_dir) / "history.csv", delimiter=",", skiprows=1, usecols=range(4),
                               dtype=str))
    assert (hist[0] == hist[1]).all() and (hist[0] == hist[2]).all()
