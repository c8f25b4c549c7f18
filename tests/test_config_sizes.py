"""Sizes a config controls are checked before anything is allocated (tuner/sizes.py): each one `error:` line
within seconds, where the same configs ended in out-of-memory tracebacks (up to 14.6 TiB requested) or gave no
answer within a minute. The limits are the written ones: 10 million samples of a signal, 500 states of a linear
closed loop, an LTI model of order 200."""

from __future__ import annotations

import time

import pytest
import yaml

from tests.conftest import REPO, one_error_line, run_tuner

LOOP = {"name": "s", "seed": 1, "objective": {
    "kind": "closed_loop", "plant": {"tf": {"num": [1.0], "den": [0.5, 1.0]}}, "controller": "pid2dof",
    "period_s": 0.01, "scenario": {"duration_s": 2.0, "reference": [{"t": 0.1, "value": 1.0}]}},
    "optimizer": {"method": "pso", "population": 4, "generations": 2}, "parallel": {"backend": "serial"}}
CARTPOLE = REPO / "configs" / "examples" / "cartpole_lqr.yaml"


def _job(tmp_path, doc) -> str:
    p = tmp_path / "job.yaml"
    p.write_text(yaml.safe_dump({**doc, "output": str(tmp_path / "runs")}))
    return str(p)


@pytest.mark.parametrize("sets, expected", [
    (["objective.scenario.duration_s=1.0e+9"], "objective.scenario.duration_s: the scenario's length in samples "
                                              "is 100,000,000,000; at most 10,000,000"),
    (["objective.period_s=1.0e-12"], "objective.scenario.duration_s: the scenario's length in samples is "
                                     "2,000,000,000,000"),
    (["objective.plant.delay_s=100"], "objective.plant.delay_s: the linear closed loop's size (plant states plus "
                                      "delayed input samples) is 10,002; at most 500"),
    (["objective.plant.tf.den=[" + ", ".join(["1.0"] * 3001) + "]"], "objective.plant.tf.den: the model's order "
                                                                     "is 3,000; at most 200"),
    (["objective.plant={zpk: {p: [" + ", ".join(["-1.0"] * 300) + "], k: 1.0}}"], "objective.plant.zpk.p: the "
                                                                                   "model's order (poles) is 300"),
])
def test_a_closed_loop_too_large_to_simulate_is_one_error_line(tmp_path, sets, expected):
    t = time.monotonic()
    out = run_tuner("run", _job(tmp_path, LOOP), *sum((["--set", s] for s in sets), []))
    one_error_line(out, expected)
    assert time.monotonic() - t < 30 and not (tmp_path / "runs").exists()


def test_a_delay_of_python_dynamics_too_long_for_memory_is_one_error_line(tmp_path):
    out = run_tuner("run", CARTPOLE, "--set", f"output={tmp_path / 'runs'}", "--set", "objective.plant.delay_s=1.0e+6")
    one_error_line(out, "objective.plant.delay_s: the input delay line's length in samples is 100,000,000")


def test_a_pendulum_profile_too_long_is_one_error_line(tmp_path):
    out = run_tuner("run", REPO / "configs" / "wmp_pid.yaml", "--set", f"output={tmp_path / 'runs'}",
                    "--set", "objective.duration_s=1.0e+9")
    one_error_line(out, "profile.duration_s: the profile's length in samples is 100,000,000,000")


@pytest.mark.parametrize("generator, rate", [("bench6dof", 1000.0), ("tilt1d", 800.0)])
def test_a_synthetic_recording_too_long_is_one_error_line(tmp_path, generator, rate):
    doc = {"name": "syn", "objective": {"kind": "filter", "filter": "madgwick" if generator == "bench6dof" else "kf1d",
                                        "data": [{"synthetic": {"generator": generator, "duration_s": 1.0e6,
                                                                "rate_hz": rate, "seed": 1}}]},
           "optimizer": {"method": "pso", "population": 4, "generations": 2}}
    for cmd in (["run", _job(tmp_path, doc)], ["evaluate", _job(tmp_path, doc)]):
        one_error_line(run_tuner(*cmd), "objective.data[0]: duration_s: the recording (duration_s x rate_hz)'s "
                                        f"length in samples is {1.0e6 * rate:,.0f}; at most 10,000,000")


def test_sizes_within_the_limits_still_run(tmp_path):
    """The limits leave room for real loops: a 0.2 s delay at a 4 ms period (50 delayed samples) runs."""
    out = run_tuner("run", _job(tmp_path, LOOP), "--set", "objective.period_s=0.004", "--set",
                    "objective.plant.delay_s=0.2", "-q", "--no-report")
    assert out.returncode == 0, out.stderr



ROBUST = REPO / "configs" / "examples" / "dc_motor_robust.yaml"
STEP = [{"t": 0.1, "value": 1.0}]


@pytest.mark.parametrize("objective, expected", [
    # three scenarios of 4 million samples each: 12 million together (each alone is within the limit)
    ({"period_s": 0.001, "scenarios": [{"name": f"s{i}", "duration_s": 4000, "reference": STEP} for i in range(3)]},
     "objective.scenarios[2].duration_s: the scenarios up to scenarios[2] together's length in samples is "
     "12,000,000; at most 10,000,000"),
    ({"uncertainty.tune.samples": 20000},
     "objective.uncertainty.tune.samples: the tuning set's size in models (nominal, corners and samples) is "
     "20,009; at most 10,000"),
    ({"uncertainty.validate.samples": 1000000},
     "objective.uncertainty.validate.samples: the held-out set's size in models is 1,000,000; at most 10,000"),
    # 9,000 held-out models x 200,000 samples (two scenarios of 100 s at 1 ms)
    ({"period_s": 0.001, "uncertainty.validate.samples": 9000,
      "scenarios": [{"name": "a", "duration_s": 100, "reference": STEP}, {"name": "b", "duration_s": 100,
                                                                          "reference": STEP}]},
     "objective.uncertainty.validate.samples: one pass of the held-out set over the scenarios in sample steps "
     "(9,000 models x 200,000 samples of all scenarios) is 1,800,000,000; at most 1,000,000,000"),
])
def test_scenario_lists_and_model_sets_too_large_are_one_error_line(tmp_path, objective, expected):
    """A scenario list's samples together, the size of each model set and a model set's pass over the scenarios
    are checked before any scenario or model is built (uncertainty.tune.samples: 10^6 drew and built every model)."""
    doc = yaml.safe_load(ROBUST.read_text())
    for key, value in objective.items():
        where = doc["objective"]
        *path, last = key.split(".")
        for k in path:
            where = where[k]
        where[last] = value
    t = time.monotonic()
    one_error_line(run_tuner("run", _job(tmp_path, doc)), expected)
    assert time.monotonic() - t < 30 and not (tmp_path / "runs").exists()


def test_a_delay_range_too_long_for_the_loop_is_one_error_line_before_tuning(tmp_path):
    """The largest delay an uncertainty block can draw is built before tuning: with tune.corners false the tuning
    samples missed the range's high end and the run tuned, then the held-out set hit a delay of over 500 loop
    states after it."""
    doc = yaml.safe_load(ROBUST.read_text())
    unc = doc["objective"]["uncertainty"]
    unc["parameters"] = {"delay_s": [0.0, 1.5]}
    unc["tune"] = {"corners": False, "samples": 1, "seed": 3}
    out = run_tuner("run", _job(tmp_path, doc))
    one_error_line(out, "objective.uncertainty.parameters.delay_s: the largest delay it can draw (1.5 s) cannot be "
                        "built: objective.plant.delay_s: the linear closed loop's size")
    assert not (tmp_path / "runs").exists()
