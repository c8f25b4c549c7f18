"""Generic closed-loop jobs end to end: configs/examples run, tune, report and export; bad plant specs
are one `error:` line with exit 2 before any tuning."""

import shutil
from pathlib import Path

import numpy as np
import pytest
import yaml

from tests.conftest import refused_job
from tests.tuner.jobs import unrendered_figures
from tuner.cli import main

ROOT = Path(__file__).resolve().parents[2]
EXAMPLES = ROOT / "configs" / "examples"


def _job(tmp_path, objective, name="bad", **over):
    cfg = {"name": name, "seed": 1, "objective": {"kind": "closed_loop", "period_s": 0.01,
                                                  "scenario": {"duration_s": 1.0}, **objective},
           "optimizer": {"method": "random", "population": 4, "generations": 1},
           "parallel": {"backend": "serial"}, "output": str(tmp_path / "runs")}
    cfg.update(over)
    p = tmp_path / f"{name}.yaml"
    p.write_text(yaml.safe_dump(cfg))
    shutil.copy(ROOT / "tests" / "control" / "loop_dynamics.py", tmp_path / "dyn.py")
    return p


BAD = {
    "non-proper tf": ({"plant": {"tf": {"num": [1.0, 0.0, 0.0], "den": [1.0, 1.0]}}},
                      "objective.plant.tf: not proper"),
    "A not square": ({"plant": {"ss": {"A": [[0, 1, 0], [1, 2, 3]], "B": [[0], [1]], "C": [[1, 0]]}}},
                     "objective.plant.ss.A: must be square"),
    "B rows": ({"plant": {"ss": {"A": [[0, 1], [-1, -1]], "B": [[0], [1], [2]], "C": [[1, 0]]}}},
               "objective.plant.ss.B: shape 3x1 does not fit; expected 2x1"),
    "C cols": ({"plant": {"ss": {"A": [[0, 1], [-1, -1]], "B": [[0], [1]], "C": [[1, 0, 0]]}}},
               "objective.plant.ss.C: shape 1x3 does not fit"),
    "delay": ({"plant": {"tf": {"num": [1.0], "den": [1.0, 1.0]}, "delay_s": 0.015}},
              "objective.plant.delay_s: 0.015 s is not a whole number"),
    "rk4 unstable": ({"plant": {"python": "dyn:stiff", "x0": [0.0], "params": {"lam": 1000.0}, "n_sub": 1}},
                     "objective.plant.n_sub: RK4 with step 0.01 s is unstable"),
    "wrong shape": ({"plant": {"python": "dyn:wrong_shape", "x0": [0.0, 0.0]}},
                    "objective.plant.python: dyn:wrong_shape returned shape (3,)"),
    "nan": ({"plant": {"python": "dyn:returns_nan", "x0": [0.0, 0.0]}},
            "objective.plant.python: dyn:returns_nan returned a non-finite dx"),
    "missing module": ({"plant": {"python": "nowhere_module:f", "x0": [0.0]}},
                       "objective.plant.python: cannot import 'nowhere_module:f'"),
    "discrete dt": ({"plant": {"tf": {"num": [1.0], "den": [1.0, -0.5]}, "dt": 0.02}},
                    "objective.plant.dt: the discrete model's period 0.02 s differs"),
    "pendulum pid": ({"plant": {"tf": {"num": [1.0], "den": [1.0, 1.0]}}, "controller": "pid"},
                     "objective.controller: unknown controller 'pid' for this plant"),
    "margin on nonlinear": ({"plant": {"python": "dyn:linear", "x0": [0.0, 0.0]}, "requirements": {"max_ms": 1.4}},
                            "objective.requirements.max_ms: margins and Ms need an LTI plant"),
    # limits no loop can meet, and signals the scenario never reaches, are errors up front (not 0 % tuned)
    "negative overshoot": ({"plant": {"tf": {"num": [1.0], "den": [1.0, 1.0]}},
                            "requirements": {"max_overshoot_pct": -5}},
                           "objective.requirements.max_overshoot_pct: -5 cannot be met; must be >= 0"),
    "ms below one": ({"plant": {"tf": {"num": [1.0], "den": [1.0, 1.0]}}, "requirements": {"max_ms": 0.5}},
                     "objective.requirements.max_ms: 0.5 cannot be met; must be >= 1"),
    "phase margin 200": ({"plant": {"tf": {"num": [1.0], "den": [1.0, 1.0]}},
                          "requirements": {"min_phase_margin_deg": 200}},
                         "objective.requirements.min_phase_margin_deg: 200 cannot be met"),
    "zero settling": ({"plant": {"tf": {"num": [1.0], "den": [1.0, 1.0]}}, "requirements": {"max_settling_time_s": 0}},
                      "objective.requirements.max_settling_time_s: 0 cannot be met; must be > 0"),
    "settling beyond window": ({"plant": {"tf": {"num": [1.0], "den": [1.0, 1.0]}},
                                "scenario": {"duration_s": 1.0, "reference": [{"t": 0.1, "value": 1.0}]},
                                "requirements": {"max_settling_time_s": 50}},
                               "objective.requirements.max_settling_time_s: 50 s is longer than the first step's "
                               "window (0.9 s)"),
    "step after the end": ({"plant": {"tf": {"num": [1.0], "den": [1.0, 1.0]}},
                            "scenario": {"duration_s": 1.0, "reference": [{"t": 5.0, "value": 1.0}]}},
                           "objective.scenario.reference[0].t: 5.0 s is after the end of the scenario"),
    "load after the end": ({"plant": {"tf": {"num": [1.0], "den": [1.0, 1.0]}},
                            "scenario": {"duration_s": 1.0, "load": [{"t": 1.5, "value": 1.0}]}},
                           "objective.scenario.load[0].t: 1.5 s is after the end of the scenario"),
    "plant a list": ({"plant": [1, 2]},
                     "objective.plant: 'wmp' or a mapping (tf, zpk, ss, python, fmu, mujoco), got [1, 2]"),
    # each plant type's own key set (checked before the builder opens anything: no fmpy needed)
    "lti unknown key": ({"plant": {"tf": {"num": [1.0], "den": [1.0, 1.0]}, "n_sub": 4}},
                        "objective.plant.n_sub: unknown key; allowed: ['delay_s', 'dt', 'inner_output', 'method', "
                        "'output', 'ss', 'tf', 'x0', 'zpk']"),
    "python unknown key": ({"plant": {"python": "dyn:linear", "x0": [0.0, 0.0], "method": "zoh"}},
                           "objective.plant.method: unknown key; allowed: ['delay_s', 'inner_output'"),
    "fmu unknown key": ({"plant": {"fmu": "nowhere.fmu", "x0": [0.0]}},
                        "objective.plant.x0: unknown key; allowed: ['delay_s', 'fmu', 'inner_output', 'inputs', "
                        "'output', 'outputs', 'parameters']"),
}


@pytest.mark.parametrize("case", sorted(BAD))
def test_bad_plant_spec_is_one_error_line(tmp_path, capsys, case):
    objective, expected = BAD[case]
    refused_job(_job(tmp_path, objective), capsys, expected)


@pytest.mark.parametrize("name", ["dc_motor_pid", "ss_lqr", "cartpole_lqr"])
@pytest.mark.slow
def test_example_runs_tunes_reports_and_exports(tmp_path, capsys, name):
    """Each example from its own folder (the cart-pendulum imports cartpole.py next to its config); the
    objective's report (figures, requirements.md) is read; the run's own report.md is left out (``--no-report``)."""
    src = yaml.safe_load((EXAMPLES / f"{name}.yaml").read_text())
    src["optimizer"].update(population=6, generations=1)
    src["output"] = str(tmp_path / "runs")
    for f in EXAMPLES.glob("*.py"):
        shutil.copy(f, tmp_path / f.name)
    path = tmp_path / f"{name}.yaml"
    path.write_text(yaml.safe_dump(src))
    assert main(["run", str(path), "--no-report"]) == 0
    run = next((tmp_path / "runs").iterdir())
    best = yaml.safe_load((run / "best.yaml").read_text())
    assert best["fitness"] < 1e12
    assert (run / "figures" / "response.png").stat().st_size > 1000
    assert (run / "requirements.md").read_text().count("|") > 6
    assert (run / "figures" / "bode.png").exists() == (name != "cartpole_lqr")
    assert not (run / "report.md").exists() and "report:" not in capsys.readouterr().out  # --no-report
    for fmt in ("yaml", "json", "python", "c"):
        assert main(["export", str(run), "--format", fmt]) == 0
        out = capsys.readouterr().out
        assert ("GAINS" in out or "C_NUM" in out) if name == "dc_motor_pid" and fmt == "c" else True
        assert ("Nbar" in out or "NBAR" in out) if name != "dc_motor_pid" else ("C_den" in out or "C_DEN" in out)


def test_describe_loop_controllers(capsys):
    assert main(["describe", "pid2dof"]) == 0
    out = capsys.readouterr().out
    assert "Ti_s" in out and "antiwindup" in out
    assert main(["describe", "lqr_sf"]) == 0
    assert "q1" in capsys.readouterr().out
    assert main(["describe", "pid"]) == 0  # the pendulum's PID keeps its name
    assert "kp1" in capsys.readouterr().out
    assert main(["describe", "plant"]) == 0
    out = capsys.readouterr().out
    assert all(k in out for k in ("tf", "zpk", "ss", "python", "fmu", "delay_s"))


def test_kind_python_imports_from_the_config_folder(tmp_path, capsys):
    (tmp_path / "my_cost.py").write_text("def f(params):\n    return (params['x'] - 1.0) ** 2\n")
    cfg = {"name": "py", "seed": 1, "objective": {"kind": "python", "callable": "my_cost:f"},
           "parameters": {"x": {"low": -2.0, "high": 2.0}},
           "optimizer": {"method": "random", "population": 4, "generations": 1},
           "parallel": {"backend": "serial"}, "output": str(tmp_path / "runs")}
    p = tmp_path / "py.yaml"
    p.write_text(yaml.safe_dump(cfg))
    assert main(["run", str(p), "--no-report"]) == 0, capsys.readouterr().err


@pytest.mark.slow
def test_same_seed_same_history_serial_and_threads(tmp_path, monkeypatch):
    from tuner.config import config_from_dict
    from tuner.run import run

    unrendered_figures(monkeypatch)  # the histories are compared, no figure nor report
    src = yaml.safe_load((EXAMPLES / "dc_motor_pid.yaml").read_text())
    src["optimizer"].update(population=6, generations=2)
    hist = []
    for i, par in enumerate(({"backend": "serial"}, {"backend": "loky", "n_jobs": 2})):
        src["output"] = str(tmp_path / f"runs{i}")
        src["parallel"] = par
        res = run(config_from_dict(src, base_dir=EXAMPLES), quiet=True, report=False)
        hist.append(np.loadtxt(Path(res.run_dir) / "history.csv", delimiter=",", skiprows=1, usecols=range(4),
                               dtype=str))
    assert (hist[0] == hist[1]).all()
