"""Several scenarios per job: their requirements, the cost's aggregation, the small-signal check (against
python-control's linear loop), and the saturation trap end to end (terminal, requirements.md, report)."""

import math
import re
from pathlib import Path

import control
import numpy as np
import pytest
import yaml

from objectives.control.objective import ClosedLoopObjective
from objectives.control.plants.robustness import assess, saturation_only, worst
from tests.conftest import run_tuner
from tests.reference import loop_metrics_reference as ref

ROOT = Path(__file__).resolve().parents[2]
EXAMPLES = ROOT / "configs" / "examples"
MOTOR = {"tf": {"num": [0.01], "den": [0.005, 0.06, 0.1001]}}
#: a PID tuned on the saturated 1 rad/s step alone (configs/examples/dc_motor_saturation.yaml, seed 1)
AGGRESSIVE = {"K": 155.55, "Ti_s": 0.180008, "Td_s": 0.0329339}


def _obj(plant=None, controller="pid2dof", **kw):
    sec = {"kind": "closed_loop", "plant": plant or MOTOR, "controller": controller,
           "period_s": kw.pop("period_s", 0.002)}
    sec.update(kw)
    return ClosedLoopObjective.from_config(sec)


def _motor(**kw):
    kw.setdefault("fixed", {"N": 10.0, "b": 1.0, "c": 0.0})
    kw.setdefault("actuator", {"u_min": -24.0, "u_max": 24.0})
    return _obj(MOTOR, **kw)


BAD = {
    "both forms": ({"scenario": {"duration_s": 1.0}, "scenarios": [{"duration_s": 1.0}]},
                   "objective.scenarios: give scenario (one) or scenarios (a list), not both"),
    "twice the name": ({"scenarios": [{"name": "a", "duration_s": 1.0}, {"name": "a", "duration_s": 1.0}]},
                       "objective.scenarios: names must differ, 'a' is given twice"),
    "bad name": ({"scenarios": [{"name": "a.b", "duration_s": 1.0}]},
                 "objective.scenarios[0].name: letters, digits, _ and - only"),
    "unknown key": ({"scenarios": [{"duration_s": 1.0, "amplitude": 2}]},
                    "objective.scenarios[0].amplitude: unknown key"),
    "margin in a scenario": ({"scenarios": [{"duration_s": 1.0, "requirements": {"max_ms": 1.5}}]},
                             "objective.scenarios[0].requirements.max_ms: margins and Ms are properties of the loop"),
    "step requirement without a step": (
        {"scenarios": [{"duration_s": 1.0, "reference": [], "load": [{"t": 0.1, "value": 1.0}],
                        "requirements": {"max_overshoot_pct": 5}}]},
        "objective.scenarios[0].requirements.max_overshoot_pct: needs a reference step"),
    "no scenario defines it": ({"scenarios": [{"duration_s": 1.0, "reference": []}],
                                "requirements": {"max_load_peak_error": 0.1}},
                               "objective.requirements.max_load_peak_error: needs a load step"),
    "unknown requirement": ({"scenario": {"duration_s": 1.0}, "requirements": {"max_overshot_pct": 5}},
                            "objective.requirements.max_overshot_pct: unknown requirement (did you mean "
                            "max_overshoot_pct?)"),
    "zero weights": ({"scenarios": [{"duration_s": 1.0, "weight": 0}]}, "objective.scenarios: the weights are all 0"),
    "aggregate": ({"scenario": {"duration_s": 1.0}, "aggregate": "median"},
                  "objective.aggregate: mean, worst, {cvar: alpha}, or {scenarios: ..., models: ...}"),
    "cvar alpha": ({"scenario": {"duration_s": 1.0}, "aggregate": {"models": {"cvar": 1.5}}},
                   "objective.aggregate.models.cvar: the tail mass alpha must be in (0, 1]"),
    "noise size": ({"scenarios": [{"duration_s": 1.0, "sensor": {"noise_std": [0.1, 0.2]}}]},
                   "objective.scenarios[0].sensor.noise_std: one value or 1 (one per measured signal), got 2"),
    "negative overshoot in a scenario": (
        {"scenarios": [{"duration_s": 1.0, "requirements": {"max_overshoot_pct": -1}}]},
        "objective.scenarios[0].requirements.max_overshoot_pct: -1 cannot be met"),
}


@pytest.mark.parametrize("case", sorted(BAD))
def test_bad_scenarios_are_one_line_naming_the_key(case):
    section, msg = BAD[case]
    with pytest.raises(ValueError) as exc:
        _obj({"tf": {"num": [1.0], "den": [1.0, 1.0]}}, period_s=0.01, **section)
    assert msg in str(exc.value) and "\n" not in str(exc.value)


def test_job_requirements_hold_where_defined_and_scenario_requirements_add():
    o = _motor(scenarios=[{"name": "big", "duration_s": 3.0, "reference": [{"t": 0.1, "value": 1.0}]},
                          {"name": "small", "duration_s": 3.0, "reference": [{"t": 0.1, "value": 0.1}],
                           "requirements": {"max_overshoot_pct": 2.0}},
                          {"name": "load", "duration_s": 2.0, "reference": [], "load": [{"t": 0.1, "value": 0.5}]}],
               requirements={"max_overshoot_pct": 5.0, "max_ms": 1.6})
    assert [c.limits for c in o.loop.cases] == [{"max_overshoot_pct": 5.0}, {"max_overshoot_pct": 2.0}, {}]
    assert o.loop.check_keys() == [("max_overshoot_pct", 0), ("max_overshoot_pct", 1), ("max_ms", None)]
    ev = o(AGGRESSIVE)
    # the small step overshoots (linear loop), the large one saturates: one reason, named by its scenario
    assert ev.status == "failed" and ev.error.count("requirement violated") == 1
    assert "in scenario small" in ev.error and "(max_overshoot_pct)" in ev.error
    assert ev.metrics["small.overshoot_pct"] > 30 > 5 > ev.metrics["big.overshoot_pct"]
    assert math.isnan(ev.metrics.get("load.overshoot_pct", math.nan)) and "load.load_peak_error" in ev.metrics


def test_max_ss_error_zero_means_a_tolerance_of_the_step():
    """0 is 0.1 % of the step: a PI loop meets it, a P loop (a steady-state error of 1 / (1 + K P(0))) does not."""
    kw = dict(plant={"tf": {"num": [1.0], "den": [1.0, 1.0]}}, period_s=0.01,
              scenario={"duration_s": 8.0, "reference": [{"t": 0.1, "value": 2.0}]},
              requirements={"max_ss_error": 0})
    pi = _obj(fixed={"K": 2.0, "Ti_s": 0.5}, **kw)
    assert pi.loop.cases[0].effective_limit("max_ss_error") == pytest.approx(0.002)
    assert pi({}).status == "ok"
    p = _obj(fixed={"K": 4.0, "Ti_s": math.inf}, **kw)({})
    assert p.status == "failed" and "steady-state error 0.4" in p.error  # 2 / (1 + 4)


def test_cost_aggregation_over_scenarios_and_models_is_the_stated_one():
    """Weighted mean over the scenarios of each model, then mean / worst / CVaR over the models, each item's
    cost computed independently from its response (NumPy reference)."""
    scen = [{"name": "a", "duration_s": 2.0, "reference": [{"t": 0.1, "value": 1.0}], "weight": 3.0},
            {"name": "b", "duration_s": 2.0, "reference": [], "load": [{"t": 0.1, "value": 1.0}], "weight": 1.0}]
    unc = {"parameters": {"tf.num[0]": {"rel": 0.4}}, "tune": {"corners": True, "samples": 3, "seed": 4}}
    costs = None
    for agg, combine in (("mean", np.mean), ("worst", np.max), ({"cvar": 0.4}, None)):
        o = _obj({"tf": {"num": [1.0], "den": [1.0, 1.0]}}, period_s=0.01, fixed={"K": 2.0, "Ti_s": 0.7},
                 scenarios=scen, uncertainty=unc, cost={"iae": 1.0, "ise": 0.5}, aggregate={"models": agg})
        if costs is None:
            costs = np.zeros((6, 2))
            for m in range(6):
                for s, case in enumerate(o.loop.cases):
                    tr = o.loop.simulate({}, m, s)
                    t = ref.cost_terms(case.signals.t, case.signals.r - tr["y"][:, 0], tr["u"][:, 0], 0.01)
                    costs[m, s] = t["iae"] + 0.5 * t["ise"]
            per_model = costs @ np.array([0.75, 0.25])
        f = o({}).fitness
        if combine is not None:
            assert f == pytest.approx(combine(per_model), rel=1e-12)
        else:  # CVaR 0.4 of six equal weights: the two worst and 0.4 of the third
            w = np.sort(per_model)[::-1]
            assert f == pytest.approx((w[0] + w[1] + 0.4 * w[2]) / 2.4, rel=1e-12)
    worst_s = _obj({"tf": {"num": [1.0], "den": [1.0, 1.0]}}, period_s=0.01, fixed={"K": 2.0, "Ti_s": 0.7},
                   scenarios=scen, uncertainty=unc, cost={"iae": 1.0, "ise": 0.5}, aggregate="worst")({}).fitness
    assert worst_s == pytest.approx(costs.max(), rel=1e-12)


def _linear_step(o, params, case):
    """python-control's closed loop of the 2-DOF PID (b = 1, c = 0: integral and proportional on the error,
    derivative on -y) on the ZOH plant, no limits: Y/R = P Cr / (1 + P C)."""
    cp = o.loop.linear_coeffs(params)
    k, ki, ad, bd = cp[0], cp[3], cp[4], cp[5]
    h = o.loop.period
    z = control.tf([1, 0], [1], h)
    C = k + ki / (z - 1) + bd * (z - 1) / (z - ad)
    Cr = k + ki / (z - 1)
    P = control.sample_system(control.ss(control.tf(MOTOR["tf"]["num"], MOTOR["tf"]["den"])), h)
    T = control.feedback(P, control.ss(C)) * control.ss(Cr)  # state space: no polynomial cancellation
    return control.forced_response(T, T=case.signals.t, U=case.signals.r).outputs.reshape(-1)


def test_small_signal_is_python_controls_linear_loop_and_shows_what_saturation_hides():
    o = _motor(scenario={"duration_s": 3.0, "reference": [{"t": 0.1, "value": 1.0}]},
               requirements={"max_overshoot_pct": 5.0, "max_settling_time_s": 1.5, "min_phase_margin_deg": 45.0})
    case = o.loop.cases[0]
    y = _linear_step(o, AGGRESSIVE, case)
    want = ref.step_quantities(case.signals.r, y, 0.002, int(case.win[0]), int(case.win[1]))
    a = assess(o.loop, "tuned", AGGRESSIVE)
    small = a.small.check("max_overshoot_pct", 0)
    assert worst(small) == pytest.approx(want["overshoot_pct"], abs=1e-6)
    assert worst(a.small.check("max_settling_time_s", 0)) == pytest.approx(want["settling_time_s"], abs=1e-9)
    assert worst(a.tuning.check("max_overshoot_pct", 0)) < 5.0 < want["overshoot_pct"]  # saturated: 1.3 %, linear: 37 %
    assert [d["key"] for d in saturation_only(a)] == ["max_overshoot_pct"]
    # a step one tenth as large never saturates: its response is the small-signal one, scaled
    o10 = _motor(scenario={"duration_s": 3.0, "reference": [{"t": 0.1, "value": 0.1}]})
    assert o10(AGGRESSIVE).metrics["overshoot_pct"] == pytest.approx(want["overshoot_pct"], abs=1e-6)
    assert a.small.check("max_overshoot_pct", 0)["values"].shape == (1,)


@pytest.mark.slow
def test_small_signal_of_a_stepped_plant_is_the_linearised_loop():
    """A Python plant with linear dynamics: the 1 % drive about the unforced run, scaled back, equals the LTI
    plant's limit-free loop (to RK4's accuracy), though the actuator saturates the scenario itself."""
    kw = dict(fixed={"K": 30.0, "Ti_s": 0.3, "Td_s": 0.05, "b": 1.0, "c": 0.0},
              scenario={"duration_s": 5.0, "reference": [{"t": 0.2, "value": 1.0}]}, period_s=0.01,
              actuator={"u_min": -3.0, "u_max": 3.0}, requirements={"max_overshoot_pct": 50.0})
    nl = _obj({"python": "tests.control.loop_dynamics:linear", "x0": [0.0, 0.0], "outputs": [0], "n_sub": 50}, **kw)
    lti = _obj({"ss": {"A": [[0, 1], [-2, -0.5]], "B": [[0], [1]], "C": [[1, 0]]}}, **kw)
    a, b = assess(nl.loop, "tuned", {}), assess(lti.loop, "tuned", {})
    o_nl, o_lti = worst(a.small.check("max_overshoot_pct", 0)), worst(b.small.check("max_overshoot_pct", 0))
    assert o_nl == pytest.approx(o_lti, abs=1e-4)
    assert abs(worst(a.tuning.check("max_overshoot_pct", 0)) - o_nl) > 1.0  # saturation changes it


def _run(tmp_path, src, **over):
    cfg = yaml.safe_load(src.read_text())
    cfg.update(over)
    cfg["output"] = str(tmp_path / "runs")
    p = tmp_path / src.name
    p.write_text(yaml.safe_dump(cfg))
    run_dir = tmp_path / ("run-" + src.stem)
    res = run_tuner("run", str(p), "--run-dir", str(run_dir), "-q")
    assert res.returncode == 0, res.stderr
    return res, run_dir


@pytest.mark.slow
def test_saturation_trap_is_reported_and_a_small_scenario_closes_it(tmp_path):
    """Tuned on the saturated step alone, the overshoot requirement holds only through saturation: the
    terminal, requirements.md and the report say so with both numbers. With a step one tenth as large added,
    the tuner finds a PID that meets every requirement in both scenarios, small-signal too."""
    res, rd = _run(tmp_path, EXAMPLES / "dc_motor_saturation.yaml")
    assert "met only through saturation" in res.stdout
    line = next(x for x in res.stdout.splitlines() if x.startswith("overshoot"))
    tuned, small = (float(v) for v in re.findall(r"\s(\d+\.\d+)\s", line)[:2])
    assert tuned <= 5.0 < small
    req = (rd / "requirements.md").read_text()
    assert "NO: met only through saturation" in req and f"{small:.4g}" in req
    html = (rd / "report.html").read_text()
    assert "met only through saturation" in html and "requirements.md" in html
    res2, rd2 = _run(tmp_path, EXAMPLES / "dc_motor_scenarios.yaml",
                     optimizer={"method": "pso", "population": 20, "generations": 20})
    assert "met only through saturation" not in res2.stdout
    rows = [x for x in (rd2 / "requirements.md").read_text().splitlines() if x.startswith("| ") and "tuning" in x]
    assert len(rows) == 8 and all(r.split(" | ")[5] == "yes" and r.split(" | ")[7] in ("yes", "-") for r in rows)
    best = yaml.safe_load((rd2 / "best.yaml").read_text())
    assert best["evaluation"]["requirements_met"] and best["evaluation"]["small_signal_met"]

