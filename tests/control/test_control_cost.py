"""Eq. 2.39 in SI units against the thesis's numbers, rise times against Table 2.4, the shared
tracking requirements and a short PSO under them (the controller comparison of a sweep:
test_controller_comparison.py)."""

import math
import pathlib

import numpy as np
import pytest
import yaml

from objectives.control.objective import ClosedLoopObjective
from objectives.control.plants.wmp.controllers.fuzzy import THESIS_OPTIMISED
from objectives.control.plants.wmp.loop import THESIS_REQUIREMENTS
from objectives.control.plants.wmp.metrics import mae_weighted_cost, rise_time_s

CONFIGS = pathlib.Path(__file__).parents[2] / "configs"
WMP_CONFIGS = ["wmp_fuzzy_protective.yaml", "wmp_pid.yaml", "wmp_lqr.yaml", "wmp_lqg.yaml"]


def _objective(name, **over):
    section = yaml.safe_load((CONFIGS / name).read_text())["objective"]
    section.update(over)
    return ClosedLoopObjective.from_config(section, CONFIGS)


@pytest.fixture(scope="module")
def fuzzy():
    return _objective("wmp_fuzzy_protective.yaml")


def test_f_at_table_2_7_initial_values_is_near_the_thesis(fuzzy):
    # thesis 2.3.4: F_init = 0.1049. Ours, SI units on the 2 s step profile: 0.1122 (+7 %); the 5 %
    # target is not met (docs/control-cost.md section 3: the run length after the last step is not in
    # the text, and 8.5 s instead of 8 s would meet it; see the next-but-one test).
    ev = fuzzy(fuzzy.defaults)
    assert ev.status == "ok"
    assert ev.fitness == pytest.approx(0.1049, rel=0.08)
    # the old mixed units (IB rate in deg/s) were 4.6x off: (180/pi)^(1.6/4) = 5.07 times the SI value
    m = ev.metrics
    mixed = mae_weighted_cost(
        np.full(3, m["mae_nu"]), np.full(3, m["mae_xi"]), np.full(3, math.degrees(m["mae_omega3"])),
        np.full(3, math.sqrt(m["ms_current"])),
    )  # fmt: skip
    assert mixed / ev.fitness == pytest.approx((180 / math.pi) ** 0.4, rel=1e-9)


def test_thesis_tuned_values_improve_f_by_about_the_thesis_ratio(fuzzy):
    # thesis: 0.1049 -> 0.0558 (-46.8 %) with the Table 2.7 optimised column; ours -40 %
    f0 = fuzzy(fuzzy.defaults).fitness
    tuned = dict(fuzzy.defaults, **{k: v for k, v in THESIS_OPTIMISED.items() if k != "p13"})
    ev = fuzzy(tuned)
    assert ev.status == "ok"  # the thesis's tuned controller meets the thesis's requirements
    assert 0.30 < 1 - ev.fitness / f0 < 0.55



def test_run_length_moves_f_init_across_the_band_but_not_the_tuned_ratio():
    """Why F_init misses 5 % (docs/control-cost.md section 3): the thesis states the step values, not how
    long the run lasts after the last step, and F (means over the run) scales with it: 2 s steps run for
    8.5 s instead of 8 s land within 5 % of 0.1049. The ratio F(thesis's tuned values) / F_init does
    not move with the run length (0.60 at 8 and 10 s; thesis 0.532), so no run length matches both."""
    prof = {"steps": [{"t": 2.0 * i, "v": v, "yaw_rate_deg_s": w}
                      for i, (v, w) in enumerate(zip((0.4, 0.0, -0.2, 0.0), (30.0, 0.0, -70.0, 0.0)))]}
    tuned = {k: v for k, v in THESIS_OPTIMISED.items() if k != "p13"}
    ratio, f_init = {}, {}
    for t_end in (8.0, 8.5, 10.0):
        obj = _objective("wmp_fuzzy_protective.yaml", profile=dict(prof, duration_s=t_end), duration_s=t_end)
        f_init[t_end] = obj(obj.defaults).fitness
        ratio[t_end] = obj(dict(obj.defaults, **tuned)).fitness / f_init[t_end]
    assert f_init[8.0] / 0.1049 - 1 > 0.05 and abs(f_init[8.5] / 0.1049 - 1) < 0.05
    assert ratio[8.0] == pytest.approx(ratio[10.0], rel=0.01) and ratio[8.0] > 0.532 * 1.1

def test_step_spacings_table_2_5_fits_equally_span_f_init_across_the_band():
    """docs/control-cost.md section 3: Table 2.5 fits step spacings of 1.94-2.08 s about equally; over them
    F_init runs from +9 % to +4 % of the thesis's 0.1049 (2 s, the configs' round middle: +6.9 %)."""
    f = {}
    for hold in (1.94, 2.08):
        prof = {"duration_s": 4 * hold,
                "steps": [{"t": hold * i, "v": v, "yaw_rate_deg_s": w}
                          for i, (v, w) in enumerate(zip((0.4, 0.0, -0.2, 0.0), (30.0, 0.0, -70.0, 0.0)))]}
        obj = _objective("wmp_fuzzy_protective.yaml", profile=prof, duration_s=None)
        f[hold] = obj(obj.defaults).fitness / 0.1049 - 1
    assert f[1.94] > 0.08 and 0.0 < f[2.08] < 0.05


def test_rise_time_closed_form_first_order_lag():
    ts, tau = 0.01, 0.2
    t = np.arange(300) * ts
    ref = np.where(t < 2.0, 0.4, 0.0)
    y = 0.4 * (1 - np.exp(-t / tau))
    expected = math.ceil(tau * math.log(10) / ts - 1e-9) * ts  # first sample at or past tau ln 10
    assert rise_time_s(y, ref, ts, 0) == pytest.approx(expected)
    # a downward step from 0.4 to 0 at 2 s, mirrored response
    y2 = np.where(t < 2.0, 0.4, 0.4 * np.exp(-(t - 2.0) / tau))
    assert rise_time_s(y2, ref, ts, 200) == pytest.approx(expected)
    assert rise_time_s(0.5 * y, ref, ts, 0) == math.inf  # never reaches 90 % before the next step
    with pytest.raises(ValueError, match="no reference step"):
        rise_time_s(y, ref, ts, 5)


@pytest.mark.parametrize("controller, thesis_rise_s", [("flc", 0.9), ("lqg", 0.73)])
def test_initial_rise_times_match_table_2_4(controller, thesis_rise_s):
    # Table 2.4 (simulation): T_rise 0.73 s linear, 0.9 s fuzzy, section 2.2's initial designs
    obj = ClosedLoopObjective(controller=controller, profile="thesis_2s")
    assert obj(obj.defaults).metrics["rise_time_nu_s"] == pytest.approx(thesis_rise_s, abs=0.1)


@pytest.mark.parametrize("name", WMP_CONFIGS)
def test_every_wmp_config_shares_the_thesis_requirements(name):
    obj = _objective(name)
    assert obj.loop.max_rise_time_s == THESIS_REQUIREMENTS["max_rise_time_s"] == 0.7
    assert obj.loop.max_mae_nu == THESIS_REQUIREMENTS["max_mae_nu"]
    assert obj.loop.max_mae_xi_deg_s == THESIS_REQUIREMENTS["max_mae_xi_deg_s"]
    assert obj.loop.profile == "thesis_2s"
    assert obj.loop.cost == {"alpha1": 1.4, "alpha2": 0.85, "beta": 1.6, "gamma": 0.4}
    ev = obj(obj.defaults)
    assert {"rise_time_nu_s", "rise_time_xi_s", "peak_theta3_deg", "peak_current_A"} <= set(ev.metrics)


def test_requirements_are_enforced_with_the_measured_value_in_the_message():
    pid = _objective("wmp_pid.yaml")
    slow = dict(pid.defaults, kp1=1.0, ki1=5.0)  # a sluggish speed loop
    ev = pid(slow)
    assert ev.status == "failed" and "max_mae_nu" in ev.error
    assert ev.metrics["mae_nu"] > 0.09
    free = _objective("wmp_pid.yaml", requirements={})  # the same run without requirements scores
    assert free(slow).status == "ok"
    rise_only = _objective("wmp_pid.yaml", requirements={"max_rise_time_s": 0.7})
    ev = rise_only(slow)
    assert ev.status == "failed" and "rise time" in ev.error and ev.metrics["rise_time_nu_s"] > 0.7
    over = _objective("wmp_pid.yaml", max_mae_nu=1.0, max_rise_time_s=10.0)  # top-level keys override
    assert over.loop.max_mae_nu == 1.0 and over.loop.max_rise_time_s == 10.0 and over.loop.max_mae_xi_deg_s == 5.0


def test_bad_requirements_name_the_key():
    with pytest.raises(ValueError, match="requirements"):
        _objective("wmp_pid.yaml", requirements={"max_rise": 1.0})
    with pytest.raises(ValueError, match="requirements"):
        _objective("wmp_pid.yaml", requirements="paper")
    with pytest.raises(ValueError, match="max_rise_time_s"):
        _objective("wmp_pid.yaml", max_rise_time_s=-1.0)


@pytest.fixture(scope="module")
def pid_run(tmp_path_factory):
    from tuner.config import load_config
    from tuner.run import run

    cfg = load_config(CONFIGS / "wmp_pid.yaml", ["optimizer.population=8", "optimizer.generations=5"], n_jobs=1)
    return run(cfg, tmp_path_factory.mktemp("pid") / "jobs" / "pid", quiet=True)


@pytest.mark.slow
def test_short_pso_improves_f_under_the_requirements(pid_run):
    ev = pid_run.extra
    assert pid_run.n_evals == 40
    assert pid_run.best_fitness < ev["initial_fitness"] and ev["improvement_pct"] > 0
    assert pid_run.best_metrics["rise_time_nu_s"] <= 0.7 and pid_run.best_metrics["mae_nu"] <= 0.09
    assert ev["best_peak_current_A"] == pytest.approx(pid_run.best_metrics["peak_current_A"])
    assert (pid_run.run_dir / "response_best.npz").exists()
    # the per-scenario block the sweep tables collect as train.* columns, and the sweep-wide figure
    row = ev["train"]["thesis_2s"]
    assert row["F"] == pytest.approx(pid_run.best_fitness)
    assert row["peak_theta3_deg"] == pytest.approx(pid_run.best_metrics["peak_theta3_deg"])
    assert row["rise_time_nu_s"] == pytest.approx(pid_run.best_metrics["rise_time_nu_s"])
    # a run does not look at its siblings: the sweep's figure comparing controllers is the engine's
    assert not (pid_run.run_dir / "figures" / "controllers.png").exists()


def test_settling_time_closed_form_first_order_decay():
    from objectives.control.plants.wmp.metrics import settling_time_s

    ts, tau, a, band = 0.01, 0.2, 30.0, 5.0
    t = np.arange(200) * ts
    ref = np.full(t.size, 0.4)
    y = a * np.exp(-t / tau)
    # first sample within the band of the end value, which is where the decay stays inside it
    expected = math.ceil(tau * math.log(a / (band + y[-1])) / ts - 1e-9) * ts
    assert settling_time_s(y, ref, ts, 0, band) == pytest.approx(expected)
    assert expected == pytest.approx(tau * math.log(a / band), abs=ts)
    assert settling_time_s(np.full(t.size, 3.0), ref, ts, 0, band) == 0.0  # never leaves the band
    y_nan = y.copy()
    y_nan[150] = np.nan  # a NaN counts as outside
    assert settling_time_s(y_nan, ref, ts, 0, band) == pytest.approx(1.51)
    # the window ends where the reference changes: a late excursion after it does not count
    ref2 = np.where(t < 1.0, 0.4, 0.0)
    y2 = np.where(t < 1.0, y, 20.0)
    assert settling_time_s(y2, ref2, ts, 0, band) == pytest.approx(expected)
    with pytest.raises(ValueError, match="band"):
        settling_time_s(y, ref, ts, 0, 0.0)


@pytest.mark.parametrize("controller, thesis_settle_s", [("flc", 1.19), ("lqg", 0.85)])
def test_ib_settling_times_match_table_2_4(controller, thesis_settle_s):
    # Table 2.4 (simulation): the IB oscillation settles within 5 deg in 0.85 s (linear) and 1.19 s
    # (fuzzy), section 2.2's initial designs; ours 0.87 s and 1.07 s
    obj = ClosedLoopObjective(controller=controller, profile="thesis_2s")
    assert obj(obj.defaults).metrics["settle_theta3_s"] == pytest.approx(thesis_settle_s, abs=0.15)


def test_ib_settling_requirement_is_optional_and_enforced(fuzzy):
    # "the oscillation of the IB is ... quickly suppressed (similarly, in less than 0.7 sec)" (2.3.4):
    # a requirement key, not in the preset (docs/control-cost.md section 4)
    assert "max_settle_theta3_s" not in THESIS_REQUIREMENTS and fuzzy.loop.max_settle_theta3_s is None
    ev = fuzzy(fuzzy.defaults)
    assert ev.status == "ok" and ev.metrics["settle_theta3_s"] > 0.7  # the initial design: 1.22 s
    strict = _objective("wmp_fuzzy_protective.yaml", max_settle_theta3_s=0.7)
    ev = strict(strict.defaults)
    assert ev.status == "failed" and "settles within 5 deg" in ev.error and "max_settle_theta3_s" in ev.error
    loose = _objective("wmp_fuzzy_protective.yaml", requirements={"max_settle_theta3_s": 2.0})
    assert loose(loose.defaults).status == "ok"
    with pytest.raises(ValueError, match="max_settle_theta3_s"):
        _objective("wmp_fuzzy_protective.yaml", max_settle_theta3_s=-1.0)


@pytest.mark.slow
def test_the_pso_improvement_turns_on_the_yaw_gains_box(tmp_path):
    """docs/control-cost.md section 3: the thesis gives no FLC bounds. In our box (u3 <= 10 V/s) the PSO
    improves F by more than the thesis's 46.8 % (56 % at this budget); with u3 bounded just above Table
    2.7's optimised 2.398 and nothing else changed it lands within 40-55 % and near the thesis's
    F_opt = 0.0558 (PSO 40 x 40 here; 150 x 150 in `make papers`)."""
    from tuner.config import load_config
    from tuner.run import run

    sets = ["optimizer.population=40", "optimizer.generations=40", "parallel.backend=threads"]
    res = {}
    for name, extra in (("ours", []), ("u3box", ["parameters.u3={low: 0.1, high: 3.0}"])):
        cfg = load_config(CONFIGS / "papers" / "wmp_fuzzy_protective.yaml", sets + extra, n_jobs=2)
        res[name] = run(cfg, tmp_path / name, quiet=True, report=False)
    f_init = res["ours"].extra["initial_fitness"]
    gain = {k: 1 - r.best_fitness / f_init for k, r in res.items()}
    assert gain["ours"] > gain["u3box"] + 0.03  # 56 % vs 50 % on seeds 1-3
    assert 0.40 <= gain["u3box"] <= 0.55
    assert res["u3box"].best_fitness == pytest.approx(0.0558, rel=0.05)
    assert res["u3box"].best.params["u3"] <= 3.0
