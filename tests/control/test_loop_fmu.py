"""FMU plants: a real FMI 2.0 co-simulation FMU compiled from C in the test (configs/examples/fmu/),
simulated by fmpy against the closed form, tuned by a short run, exported; bad FMU specs are one
`error:` line. Skipped without fmpy or a C compiler."""

import importlib.util
import shutil
from pathlib import Path

import numpy as np
import pytest
import yaml

from tuner.cli import main

pytest.importorskip("fmpy", reason="FMU plants need the optional extra fmpy (pip install -e '.[fmu]')")
if shutil.which("cc") is None and shutil.which("gcc") is None:
    pytest.skip("no C compiler to build the test FMU", allow_module_level=True)

ROOT = Path(__file__).resolve().parents[2]
EX = ROOT / "configs" / "examples" / "fmu"


@pytest.fixture(scope="module")
def fmu_dir(tmp_path_factory):
    spec = importlib.util.spec_from_file_location("build_fmu", EX / "build_fmu.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    d = tmp_path_factory.mktemp("fmu")
    mod.build(d)
    shutil.copy(EX / "first_order_pid.yaml", d / "first_order_pid.yaml")
    return d


def test_fmu_open_loop_step_is_the_closed_form(fmu_dir):
    from objectives.control.objective import ClosedLoopObjective

    o = ClosedLoopObjective.from_config({
        "kind": "closed_loop", "plant": {"fmu": "first_order.fmu", "inputs": ["u"], "outputs": ["y"],
                                         "parameters": {"K": 3.0, "T": 0.2}},
        "controller": "open_loop", "period_s": 0.01,
        "scenario": {"duration_s": 1.0, "reference": [{"t": 0.0, "value": 1.0}]}}, fmu_dir)
    s = o.simulate({})
    assert np.allclose(s["y"][:, 0], 3.0 * (1 - np.exp(-s["t"] / 0.2)), atol=1e-12)
    s2 = o.simulate({})  # every simulation starts from the reset FMU
    assert np.array_equal(s["y"], s2["y"])


def test_fmu_pid_equals_the_same_plant_as_a_transfer_function(fmu_dir):
    """The FMU's first-order plant and tf 2 / (0.5 s + 1) under the same PI give the same loop."""
    from objectives.control.objective import ClosedLoopObjective

    common = {"kind": "closed_loop", "controller": "pid2dof", "period_s": 0.01,
              "fixed": {"K": 2.0, "Ti_s": 0.3}, "actuator": {"u_min": -5.0, "u_max": 5.0},
              "scenario": {"duration_s": 3.0, "reference": [{"t": 0.1, "value": 1.0}],
                           "load": [{"t": 2.0, "value": -0.3}]}}
    a = ClosedLoopObjective.from_config({**common, "plant": {"fmu": "first_order.fmu", "inputs": ["u"],
                                                             "outputs": ["y"], "parameters": {"K": 2.0, "T": 0.5}}},
                                        fmu_dir)
    b = ClosedLoopObjective.from_config({**common, "plant": {"tf": {"num": [2.0], "den": [0.5, 1.0]}}}, fmu_dir)
    assert np.allclose(a.simulate({})["y"], b.simulate({})["y"], atol=1e-10)
    assert a({}).fitness == pytest.approx(b({}).fitness, rel=1e-9)


def test_fmu_job_tunes_reports_and_exports(fmu_dir, capsys):
    src = yaml.safe_load((fmu_dir / "first_order_pid.yaml").read_text())
    src["optimizer"].update(population=6, generations=2)
    src["output"] = str(fmu_dir / "runs")
    path = fmu_dir / "job.yaml"
    path.write_text(yaml.safe_dump(src))
    assert main(["run", str(path), "--no-report"]) == 0  # response.png is the objective's figure
    run = next((fmu_dir / "runs").iterdir())
    best = yaml.safe_load((run / "best.yaml").read_text())
    assert best["fitness"] < 1e12 and (run / "figures" / "response.png").exists()
    capsys.readouterr()
    assert main(["export", str(run), "--format", "c"]) == 0
    assert "C_DEN" in capsys.readouterr().out


@pytest.mark.parametrize("plant,expected", [
    ({"fmu": "first_order.fmu", "inputs": ["v"], "outputs": ["y"]},
     "objective.plant.inputs: 'v' is not a Real input of first_order.fmu; its inputs: ['u']"),
    ({"fmu": "first_order.fmu", "inputs": ["u"], "outputs": ["K"]},
     "objective.plant.outputs: 'K' is not a Real output"),
    ({"fmu": "first_order.fmu", "inputs": ["u"], "outputs": ["y"], "parameters": {"Tau": 1.0}},
     "objective.plant.parameters: 'Tau' is not a Real parameter"),
    ({"fmu": "missing.fmu", "inputs": ["u"], "outputs": ["y"]}, "objective.plant.fmu: no such file"),
])
def test_bad_fmu_spec_is_one_error_line(fmu_dir, capsys, plant, expected):
    cfg = {"name": "bad", "seed": 1, "objective": {"kind": "closed_loop", "plant": plant, "period_s": 0.01,
                                                   "scenario": {"duration_s": 1.0}},
           "optimizer": {"method": "random", "population": 2, "generations": 1}, "parallel": {"backend": "serial"},
           "output": str(fmu_dir / "bad_runs")}
    p = fmu_dir / "bad.yaml"
    p.write_text(yaml.safe_dump(cfg))
    assert main(["run", str(p)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and expected in err[0], err


def test_fmu_parameters_under_uncertainty_are_the_transfer_function_models(fmu_dir):
    """parameters.K and parameters.T of the FMU drawn like tf.num[0] and tf.den[0] of K / (T s + 1): every
    model of both tuning sets gives the same statistics (one FMU instance per model, reset each run; the
    mean |state| apart: an FMU's state is its output, a transfer function's its realisation's)."""
    from objectives.control.objective import ClosedLoopObjective

    common = {"kind": "closed_loop", "controller": "pid2dof", "period_s": 0.01, "fixed": {"K": 2.0, "Ti_s": 0.3},
              "scenario": {"duration_s": 1.0, "reference": [{"t": 0.1, "value": 1.0}]}}
    tune = {"corners": True, "samples": 2, "seed": 3}
    fmu = {"fmu": "first_order.fmu", "inputs": ["u"], "outputs": ["y"], "parameters": {"K": 2.0, "T": 0.5}}
    a = ClosedLoopObjective.from_config({**common, "plant": fmu,
                                         "uncertainty": {"parameters": {"parameters.K": {"rel": 0.3},
                                                                        "parameters.T": [0.3, 0.8]}, "tune": tune}},
                                        fmu_dir)
    b = ClosedLoopObjective.from_config({**common, "plant": {"tf": {"num": [2.0], "den": [0.5, 1.0]}},
                                         "uncertainty": {"parameters": {"tf.num[0]": {"rel": 0.3},
                                                                        "tf.den[0]": [0.3, 0.8]}, "tune": tune}},
                                        fmu_dir)
    assert [p.parameters for p in a.loop.models.plants[1:3]] == [{"K": 1.4, "T": 0.3}, {"K": 1.4, "T": 0.8}]
    sa, sb = a.loop._runner.run(a.coeffs({})), b.loop._runner.run(b.coeffs({}))
    assert sa.shape == sb.shape == (1, 7, 1, sa.shape[-1])
    assert np.allclose(sa[..., :-1], sb[..., :-1], rtol=1e-8, atol=1e-10, equal_nan=True)
