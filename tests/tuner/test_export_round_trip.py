"""Every filter kind and every controller kind: a 1-generation run, its best parameters exported as YAML,
JSON and Python, read back, the filter/controller rebuilt from them, and the same score as
`tuner evaluate` of the run (tuner.rescore.evaluate_target, which the command calls)."""

import math
import subprocess
import sys

import numpy as np
import pytest
import yaml

from tests.tuner.jobs import unrendered  # noqa: F401 (the module fixture)
from tuner.export import export
from tuner.export_formats import json_load
from tuner.registry import REGISTRY
from tuner.rescore import evaluate_target

FILTERS = REGISTRY.catalog()["filters"][1]
CONTROLLERS = REGISTRY.catalog()["controllers"][1]


def _names(family):
    from objectives.control.controllers import controllers_of

    return set(controllers_of(family))


#: controllers of the pendulum (plant: wmp) and of any plant (objectives/control/plants), tested apart; those of
#: MuJoCo models take their parameters from the model (tests/control/test_mujoco_jobs.py exports each)
WMP_CONTROLLERS = [n for n in CONTROLLERS if n in _names("wmp")]
LOOP_CONTROLLERS = [n for n in CONTROLLERS if n in _names("siso")]
#: a plant every loop controller runs on (two outputs for the cascade, states for LQR)
LOOP_OBJECTIVE = {"kind": "closed_loop", "period_s": 0.05,
                  "plant": {"ss": {"A": [[0.0, 1.0], [-1.0, -2.0]], "B": [[0.0], [1.0]], "C": [[1.0, 0.0], [0.0, 1.0]]},
                            "output": 0, "inner_output": 1},
                  "scenario": {"duration_s": 3.0, "reference": [{"t": 0.5, "value": 1.0}]}}


# No test here reads a figure or the run report: the objective's figures are not rendered, and the runs
# leave out the report (report=False).
pytestmark = pytest.mark.usefixtures("unrendered")


def _tiny_run(tmp, objective):
    from tuner.config import config_from_dict
    from tuner.run import run

    raw = {"name": "roundtrip", "seed": 5, "objective": objective,
           "optimizer": {"method": "pso", "population": 3, "generations": 1}, "parallel": {"backend": "serial"}}
    return run(config_from_dict(raw, base_dir=tmp), run_dir=tmp / "r", quiet=True, report=False).run_dir


def _filter_objective(name):
    if name.endswith("1d"):  # the thesis's 1-D filters: tilt angle, eq. 3.18
        data = [{"synthetic": {"generator": "tilt1d", "duration_s": 5.0, "rate_hz": 200.0, "seed": 1}}]
        return {"kind": "filter", "filter": name, "data": data, "metric": "mse_1d"}
    data = [{"synthetic": {"generator": "bench6dof", "duration_s": 5.0, "rate_hz": 200.0, "seed": 1}}]
    return {"kind": "filter", "filter": name, "data": data, "warmup_s": 1.0}


def _loaded(run_dir, tmp):
    """The exported parameters read back from each format."""
    (tmp / f"exp_{run_dir.parent.name}.py").write_text(export(run_dir, "python"))
    code = f"import json, exp_{run_dir.parent.name} as m; print(json.dumps(m.PARAMS, allow_nan=True))"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=tmp)
    assert out.returncode == 0, out.stderr
    return {"yaml": yaml.safe_load(export(run_dir, "yaml"))["params"],
            "json": json_load(export(run_dir, "json"))["params"],
            "python": __import__("json").loads(out.stdout)}


def _same(a, b):
    return a == b or (isinstance(a, float) and isinstance(b, float) and math.isnan(a) and math.isnan(b))


def _check_scores(run_dir, tmp, rebuild):
    best = yaml.safe_load((run_dir / "best.yaml").read_text())
    reference = evaluate_target(run_dir)   # `tuner evaluate RUN_DIR`: the run's best
    assert reference["fitness"] == pytest.approx(best["fitness"], rel=1e-9, abs=0.0)
    for fmt, params in _loaded(run_dir, tmp).items():
        # every deployed value: the run's point (init resolved from auto to the run's start) and the rest
        assert set(best["params"]) <= set(params), fmt
        assert all(_same(params[k], best["params"][k]) for k in best["params"] if k != "init"), fmt
        rebuild(params, best["params"])
        pfile = tmp / f"{fmt}.yaml"
        pfile.write_text(yaml.safe_dump({"params": params}))
        assert evaluate_target(run_dir, params_file=pfile)["fitness"] == reference["fitness"], fmt


@pytest.mark.parametrize("name", FILTERS)
@pytest.mark.slow
def test_filter_export_round_trip(name, tmp_path):
    from objectives.attitude.data.synthetic import synthetic
    from objectives.attitude.filters import get_filter

    run_dir = _tiny_run(tmp_path, _filter_objective(name))
    cls = get_filter(name)
    gen = "tilt1d" if name.endswith("1d") else "bench6dof"
    rec = synthetic(gen, duration_s=2.0, rate_hz=200.0, seed=3)

    def rebuild(params, best):  # the filter built from the exported values runs as the one from best.yaml
        q_exp = cls(**{k: v for k, v in params.items() if k in cls.defaults}).run(rec)
        q_best = cls.from_run(run_dir).run(rec)
        np.testing.assert_array_equal(q_exp, q_best)

    _check_scores(run_dir, tmp_path, rebuild)


@pytest.mark.parametrize("name", LOOP_CONTROLLERS)
@pytest.mark.slow
def test_loop_controller_export_round_trip(name, tmp_path):
    from objectives.control.objective import ClosedLoopObjective

    objective = {**LOOP_OBJECTIVE, "controller": name}
    run_dir = _tiny_run(tmp_path, objective)
    obj = ClosedLoopObjective.from_config(objective)

    def rebuild(params, best):  # the discrete controller's coefficients from the exported values
        np.testing.assert_array_equal(obj.coeffs(params), obj.coeffs(best))

    _check_scores(run_dir, tmp_path, rebuild)


@pytest.mark.parametrize("name", WMP_CONTROLLERS)
@pytest.mark.slow
def test_controller_export_round_trip(name, tmp_path):
    from objectives.control.controllers import get_controller

    run_dir = _tiny_run(tmp_path, {"kind": "closed_loop", "controller": name, "profile": "thesis_2s",
                                   "duration_s": 2.0, "requirements": None})
    cls = get_controller(name)

    def rebuild(params, best):  # the kernel's parameter array (gains, LUTs...) from the exported values
        np.testing.assert_array_equal(cls().param_array(params), cls().param_array(best))

    _check_scores(run_dir, tmp_path, rebuild)
