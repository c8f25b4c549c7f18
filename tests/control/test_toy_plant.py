"""A plant kind added from the test suite alone: one class implementing the ``Plant`` protocol (its stepped
variant) and one registration, then a PID tuned on it through the normal YAML path (``tuner run``).

The toy is a first-order lag ``tau dx/dt = K u - x`` advanced by its exact zero-order-hold step
``x+ = a x + K (1 - a) u``, ``a = exp(-h / tau)``, written here by hand; python-control's discretisation of
the transfer function ``K / (tau s + 1)`` (the ``tf`` kind, a different plant variant and loop kernel) is
the independent reference: both loops must give the same response.
"""

import math
from dataclasses import dataclass, field

import numpy as np
import pytest
import yaml

from objectives.control.objective import ClosedLoopObjective
from objectives.control.plants import PLANTS, plant_kind, register_plant, unregister_plant
from objectives.control.plants.base import Plant, PlantKind, SteppedPlant
from objectives.control.plants.kernels import _loop_nl
from tests.control.jobs import pi_job
from tuner.cli import main

KEY = "toy_first_order"


@dataclass
class FirstOrder(SteppedPlant):
    """``tau dx/dt = K u - x``, y = x, stepped exactly over each period."""

    K: float
    tau_s: float
    period_s: float
    model: str = KEY
    delay_n: int = 0
    output: int = 0
    inner_output: int = -1
    n_sub: int = 1
    x0: np.ndarray = field(default_factory=lambda: np.zeros(1))
    outputs: np.ndarray = field(default_factory=lambda: np.zeros(1, dtype=np.int64))
    fn: object = None
    params: object = None

    n_states = 1
    n_inputs = 1

    def stepper(self):
        a = math.exp(-self.period_s / self.tau_s)
        b = self.K * (1.0 - a)

        def step(_f, x, u, _t, _params, _h, _n_sub):
            return np.array([a * x[0] + b * u[0]])

        return _loop_nl.py_func, step

    def design_model(self):
        a = math.exp(-self.period_s / self.tau_s)
        return np.array([[a]]), np.array([[self.K * (1.0 - a)]])

    def tracked_row(self):
        return np.ones(1)

    def named_parameters(self):
        return {"K": self.K, "tau_s": self.tau_s}


def build(spec, period_s, base_dir, key):
    body = spec[KEY]
    if not isinstance(body, dict) or set(body) != {"K", "tau_s"} or not body["tau_s"] > 0:
        raise ValueError(f"{key}.{KEY}: expected {{K, tau_s > 0}}, got {body!r}")
    return FirstOrder(float(body["K"]), float(body["tau_s"]), float(period_s))


TOY = PlantKind(KEY, frozenset({KEY}), build, "siso", "{K, tau_s}: a first-order lag (a test's own plant)")


@pytest.fixture
def toy():
    register_plant(TOY)
    yield TOY
    unregister_plant(KEY)


SCENARIO = {"duration_s": 3.0, "reference": [{"t": 0.1, "value": 1.0}], "load": [{"t": 2.0, "value": 0.3}]}


def test_the_toy_plant_is_a_plant_and_its_loop_equals_the_lti_kind(toy):
    assert plant_kind({KEY: {"K": 2.0, "tau_s": 0.5}}) is TOY
    common = {"controller": "pid2dof", "period_s": 0.01, "scenario": SCENARIO,
              "actuator": {"u_min": -2.0, "u_max": 2.0}, "fixed": {"K": 1.5, "Ti_s": 0.4, "Td_s": 0.02}}
    mine = ClosedLoopObjective.from_config({"plant": {KEY: {"K": 2.0, "tau_s": 0.5}}, **common})
    ref = ClosedLoopObjective.from_config({"plant": {"tf": {"num": [2.0], "den": [0.5, 1.0]}}, **common})
    assert isinstance(mine.loop.plant, Plant) and not mine.loop.plant.linear
    a, b = mine.simulate({}), ref.simulate({})
    assert a["status"] == b["status"] == 0
    np.testing.assert_allclose(a["y"], b["y"], rtol=0, atol=1e-12)
    np.testing.assert_allclose(a["u"], b["u"], rtol=0, atol=1e-11)
    assert mine({}).fitness == pytest.approx(ref({}).fitness, rel=1e-10)


def test_a_pid_is_tuned_on_the_toy_plant_from_yaml(toy, tmp_path, capsys):
    path, job = pi_job(tmp_path, "toy", {
        "kind": "closed_loop", "plant": {KEY: {"K": 2.0, "tau_s": 0.5}}, "controller": "pid2dof", "period_s": 0.01,
        "scenario": SCENARIO, "actuator": {"u_min": -5.0, "u_max": 5.0}, "fixed": {"Td_s": 0.0}, "cost": {"iae": 1.0}},
        K=(0.1, 20.0), Ti_s=(0.02, 5.0), population=8, generations=6)
    assert main(["run", str(path), "--no-report"]) == 0
    run = next((tmp_path / "runs").iterdir())
    best = yaml.safe_load((run / "best.yaml").read_text())
    obj = ClosedLoopObjective.from_config(job["objective"])
    tuned, untuned = obj(best["params"]), obj({})
    assert tuned.status == "ok" and tuned.fitness == pytest.approx(best["fitness"], rel=1e-12)
    assert tuned.fitness < 0.5 * untuned.fitness  # the defaults (K = 1, Ti = 1 s) are slow on this lag
    assert (run / "figures" / "response.png").stat().st_size > 1000  # the loop's own report
    assert KEY in PLANTS


def test_the_registry_refuses_a_second_kind_of_one_key(toy):
    with pytest.raises(ValueError, match="already registered"):
        register_plant(TOY)
    with pytest.raises(ValueError, match="unknown family"):
        register_plant(PlantKind("other_toy", frozenset({"other_toy"}), build, "no_such_loop"))
