"""What you deploy is what you tuned: every filter kind and every controller kind, tuned briefly with
non-default fixed options, exported as YAML, JSON, a Python module and a C header (compiled with
``cc -std=c99 -Wall -Wextra -Werror -pedantic``, its values printed by the program), rebuilt from each
export and scored: the run's best fitness, exactly. The filter of ``from_run`` runs on plain arrays
without truth, and its estimates, scored here with :func:`objectives.attitude.metrics.euler_stats`
(not the objective's fused error pass), give the run's fitness too."""

import json
import math
import shutil
import subprocess
import sys

import numpy as np
import pytest
import yaml

from tests.conftest import run_tuner
from tests.tuner.jobs import unrendered  # noqa: F401 (the module fixture)

# the pendulum's controllers and those of any plant, with the plant the latter run on
from tests.tuner.test_export_round_trip import LOOP_CONTROLLERS, LOOP_OBJECTIVE, WMP_CONTROLLERS
from tuner.deployment import Deployment, load_deployment
from tuner.export import export
from tuner.export_formats import json_load
from tuner.registry import REGISTRY
from tuner.rescore import evaluate_target

FILTERS = REGISTRY.catalog()["filters"][1]
CONTROLLERS = REGISTRY.catalog()["controllers"][1]
HAS_CC = shutil.which("cc") is not None

#: options away from their defaults, per filter kind (the round trip must carry every one of them)
NONDEFAULT = {
    "akf1d": {"window": 200, "fft_length": 256, "K3": 12.0, "init": "accmag"},
    "ccf": {"alpha_mode": "tau", "tau_s": 0.5, "mag_rejection": True, "mag_weight": 0.5, "acc_lp_tau_s": 0.5,
            "init": "broad"},
    "ekf": {"integration": "euler", "gyro_sample": "current", "mag_rejection": True, "rest_bias": True,
            "acc_gate": 3.0, "init": "broad"},
    "faekf": {"integration": "euler", "window": 200, "fft_length": 256, "rest_bias": True, "init": "broad"},
    "kf1d": {"p0_theta": 0.01, "p0_bias": 1e-6, "init": "accmag"},
    "lcf": {"alpha_mode": "tau", "tau_s": 0.5, "use_mag": False},
    "madgwick": {"variant": "original_c", "mag_rejection": True, "rest_bias": True, "acc_lp_tau_s": 1.0,
                 "mag_ref_start": False, "init": "broad"},
    "madgwick1d": {"exact_step": False, "init": "accmag"},
    "mahony": {"mag_rejection": True, "rest_bias": True, "Ki": 0.01, "rest_bias_tau_s": 1.0, "init": "broad"},
    "mahony1d": {"exact_step": False, "Ki": 0.01},
    "ncf": {"use_mag": False, "Ki": 0.2},
    "qraukf": {"window": 10, "mag_rejection": True, "rest_bias": True, "init": "broad"},
    "qukf": {"p0_att": 0.2, "p0_bias": 0.02, "init": "broad"},
    "vqf": {"offline": True, "magDistRejectionEnabled": False, "tauMag": 5.0},
    "realtime": {"mag_first_at_rest": True, "mag_recover_tau_s": 4.0, "motion_bias": False, "start": "q0"},
    "imu_tools_madgwick": {"world_frame": "ned", "zeta": 0.02, "mag_bias_x": 1.5, "init": "broad"},
    "valenti": {"use_mag": True, "do_adaptive_gain": False, "do_bias_estimation": False, "init": "broad"},
}


# No test here reads a figure or the run report: the objective's figures are not rendered, and the runs
# leave out the report (report=False).
pytestmark = pytest.mark.usefixtures("unrendered")


def _tiny_run(tmp, objective, parameters=None, name="deploy"):
    from tuner.config import config_from_dict
    from tuner.run import run

    raw = {"name": name, "seed": 5, "objective": objective,
           "optimizer": {"method": "pso", "population": 3, "generations": 1}, "parallel": {"backend": "serial"}}
    if parameters is not None:
        raw["parameters"] = parameters
    return run(config_from_dict(raw, base_dir=tmp), run_dir=tmp / name, quiet=True, report=False).run_dir


def _data(name):
    gen = "tilt1d" if name.endswith("1d") else "bench6dof"
    return {"synthetic": {"generator": gen, "duration_s": 4.0, "rate_hz": 200.0, "seed": 1}}


def _same(a, b):
    return a == b or (isinstance(a, float) and isinstance(b, float) and math.isnan(a) and math.isnan(b))


# --- reading every export back -------------------------------------------------------------------
def _from_python(run_dir, tmp):
    mod = f"deployed_{run_dir.name.replace('-', '_')}"
    (tmp / f"{mod}.py").write_text(export(run_dir, "python"))
    code = f"import json, {mod} as m; print(json.dumps(m.PARAMS, allow_nan=True))"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=tmp, timeout=120)
    assert out.returncode == 0, out.stderr
    return json.loads(out.stdout)


def _from_c(run_dir, tmp, dep: Deployment):
    """Compile a program that includes the header and prints every value; rebuild the values from its
    output (booleans from 0/1, choices from the index of their ``#define``)."""
    header = tmp / "deployed.h"
    header.write_text(export(run_dir, "c", prefix="DEP"))
    prints = []
    for name, v in dep.values.items():
        ident = "DEP_" + "".join(c if c.isalnum() or c == "_" else "_" for c in name).upper()
        if isinstance(v, float):
            prints.append(f'printf("%.17g\\n", {ident});')
        elif isinstance(v, (bool, int, str)):
            prints.append(f'printf("%d\\n", {ident});')
        else:
            raise AssertionError(f"{name}: {v!r} has no C form")
    (tmp / "main.c").write_text('#include <stdio.h>\n#include "deployed.h"\nint main(void) {\n'
                                + "\n".join(prints) + "\nreturn 0;\n}\n")
    cc = subprocess.run(["cc", "-std=c99", "-Wall", "-Wextra", "-Werror", "-pedantic", "-o", "main", "main.c",
                         "-lm"], cwd=tmp, capture_output=True, text=True, timeout=120)
    assert cc.returncode == 0, cc.stderr
    out = subprocess.run([str(tmp / "main")], capture_output=True, text=True, timeout=30).stdout.split()
    values = {}
    for (name, v), text in zip(dep.values.items(), out, strict=True):
        if isinstance(v, bool):
            values[name] = {"0": False, "1": True}[text]
        elif isinstance(v, str):
            values[name] = dep.choices[name][int(text)]
        elif isinstance(v, int):
            values[name] = int(text)
        else:
            values[name] = float(text)
    return values


def _exports(run_dir, tmp):
    dep = load_deployment(run_dir)
    out = {"yaml": yaml.safe_load(export(run_dir, "yaml"))["params"],
           "json": json_load(export(run_dir, "json"))["params"],
           "python": _from_python(run_dir, tmp)}
    if HAS_CC:
        out["c"] = _from_c(run_dir, tmp, dep)
    return dep, out


def _check_exports(run_dir, tmp, rebuild):
    """Every format holds every deployed value, and what is rebuilt from it scores the run's fitness."""
    best = yaml.safe_load((run_dir / "best.yaml").read_text())
    dep, loaded = _exports(run_dir, tmp)
    for fmt, values in loaded.items():
        assert values.keys() == dep.values.keys() and all(_same(values[k], dep.values[k]) for k in values), fmt
        rebuild(fmt, values)
        pfile = tmp / f"{fmt}.yaml"
        pfile.write_text(yaml.safe_dump({"params": values}))
        assert evaluate_target(run_dir, params_file=pfile)["fitness"] == best["fitness"], fmt
    return dep


# --- filters -------------------------------------------------------------------------------------
def test_every_filter_kind_has_non_default_options():
    assert sorted(NONDEFAULT) == sorted(FILTERS)


def _check_controller_exports(run_dir, tmp_path, obj, name, fixed):
    """:func:`_check_exports` of a closed-loop run: every export rebuilds the controller (its parameter
    array equal to the one of best.yaml's params), and the deployment keeps the name and the fixed values."""

    def rebuild(fmt, values):
        built = obj.build(values)
        np.testing.assert_array_equal(built.param_array(), obj.build(yaml.safe_load(
            (run_dir / "best.yaml").read_text())["params"]).param_array(), err_msg=fmt)
        assert built.values == dict(values)

    dep = _check_exports(run_dir, tmp_path, rebuild)
    assert dep.kind == "closed_loop" and dep.name == name and set(fixed) <= set(dep.names("fixed"))
    assert {k: dep.values[k] for k in fixed} == fixed
    return dep


@pytest.mark.parametrize("name", [pytest.param(n, marks=pytest.mark.slow) if n == "qraukf" else n for n in FILTERS])
def test_filter_deployment_round_trip(name, tmp_path):
    from objectives.attitude import metrics as M
    from objectives.attitude.data.synthetic import synthetic
    from objectives.attitude.filters import get_filter
    from objectives.attitude.filters.base import AttitudeFilter

    if name == "vqf":
        pytest.importorskip("vqf", reason="the optional vqf package is not installed")
    cls = get_filter(name)
    fixed = NONDEFAULT[name]
    assert all(cls.defaults[k] != v for k, v in fixed.items())  # really away from the defaults
    warm = 0.5
    run_dir = _tiny_run(tmp_path, {"kind": "filter", "filter": name, "data": [_data(name)], "fixed": fixed,
                                   "metric": "euler_rmse_mean", "warmup_s": warm})
    best = yaml.safe_load((run_dir / "best.yaml").read_text())
    assert math.isfinite(best["fitness"])
    spec = dict(_data(name)["synthetic"])
    rec = synthetic(spec.pop("generator"), **spec)
    flt = cls.from_run(run_dir)
    assert {k: flt.values[k] for k in fixed} == fixed  # the fixed options leave the run

    def rebuild(fmt, values):  # the filter built from the exported values runs as the one from best.yaml
        np.testing.assert_array_equal(cls(**values).run(rec), flt.run(rec), err_msg=fmt)

    dep = _check_exports(run_dir, tmp_path, rebuild)
    assert dep.kind == "filter" and dep.name == name and set(dep.values) == set(cls.defaults)
    assert {k for k in fixed} <= set(dep.names("fixed")) and set(dep.names("searched")) <= set(cls.defaults)
    # from_run on plain arrays (no truth), scored independently against the truth: the run's fitness
    gen = AttitudeFilter.from_run(run_dir)
    assert type(gen) is cls and gen.values == flt.values
    mag = rec.mag if flt.values.get("use_mag", True) and rec.mag is not None else None
    q = flt.run(rec.gyr.copy(), rec.acc.copy(), None if mag is None else mag.copy(), rate_hz=200.0, frame=rec.frame)
    mask = rec.motion.copy()
    mask[: int(round(warm / rec.dt))] = False
    stats = M.euler_stats(q, rec.quat, mask)
    assert float(np.mean(stats.rmse_deg)) == pytest.approx(best["fitness"], rel=1e-9, abs=1e-12)


def test_truth_start_is_scoring_only_and_from_run_works_on_live_arrays(tmp_path):
    """``init: truth`` (written as ``parameters: {init: {fixed: truth}}``) is never exported as part of
    the filter: C has no string, the deployed filter starts from acc/mag, runs without truth, and with
    the scoring start restored the exported values give the run's fitness."""
    from objectives.attitude.data.synthetic import synthetic
    from objectives.attitude.filters.mahony import Mahony

    run_dir = _tiny_run(tmp_path, {"kind": "filter", "filter": "mahony", "data": [_data("mahony")],
                                   "fixed": {"mag_rejection": True}},
                        {"Kp": {"low": 0.1, "high": 2.0, "scale": "log"}, "init": {"fixed": "truth"}})
    best = yaml.safe_load((run_dir / "best.yaml").read_text())
    dep = load_deployment(run_dir)
    assert dep.values["init"] == "accmag" and dep.scoring["init"] == "truth" and dep.notes
    assert "truth" not in dep.choices["init"]
    header = export(run_dir, "c", prefix="M")
    assert "truth" not in header.split("#ifndef")[1] and "static const int M_INIT = M_INIT_ACCMAG;" in header
    assert "Scoring only" in header and "init = \"truth\"" in header  # said in the comment, not a value
    rec = synthetic("bench6dof", duration_s=4.0, rate_hz=200.0, seed=1)
    flt = Mahony.from_run(run_dir)
    assert flt.values["mag_rejection"] is True and flt.values["init"] == "accmag"
    q = flt.run(rec.gyr, rec.acc, rec.mag, rate_hz=200.0)  # live data: no truth needed
    assert q.shape == (rec.n, 4) and np.isfinite(q).all()
    s = flt.stream(rate_hz=200.0)
    np.testing.assert_allclose([s.update(g, a, m) for g, a, m in zip(rec.gyr[:5], rec.acc[:5], rec.mag[:5])], q[:5],
                               rtol=0, atol=1e-12)
    scoring = {**yaml.safe_load(export(run_dir, "yaml"))["params"], "init": dep.scoring["init"]}
    pfile = tmp_path / "p.yaml"
    pfile.write_text(yaml.safe_dump({"params": scoring}))
    assert evaluate_target(run_dir, params_file=pfile)["fitness"] == best["fitness"]
    assert evaluate_target(run_dir)["deployment"]["values"]["init"] == "accmag"


def test_both_ways_of_writing_a_fixed_value_deploy_the_same_filter(tmp_path):
    obj = {"kind": "filter", "filter": "mahony", "data": [_data("mahony")]}
    a = _tiny_run(tmp_path, {**obj, "fixed": {"rest_bias": True, "Ki": 0.01}},
                  {"Kp": {"low": 0.1, "high": 2.0, "scale": "log"}}, name="a")
    b = _tiny_run(tmp_path, obj, {"Kp": {"low": 0.1, "high": 2.0, "scale": "log"}, "rest_bias": True,
                                  "Ki": {"fixed": 0.01}}, name="b")
    da, db = load_deployment(a), load_deployment(b)
    assert da.values == db.values and da.values["rest_bias"] is True and da.values["Ki"] == 0.01
    assert da.sources == db.sources and da.names("searched") == ["Kp"]
    assert set(da.names("fixed")) == {"rest_bias", "Ki"}


# --- controllers ---------------------------------------------------------------------------------
#: controller options away from their defaults (every controller kind gets at least one)
def _controller_fixed(cls):
    out = {}
    for p in cls.decl or ():
        if p.choices and not isinstance(p.default, bool):
            out[p.name] = next(c for c in p.choices if c != p.default)
        elif isinstance(p.default, bool):
            out[p.name] = not p.default
    if not out:  # no options: pin one searched value away from its default
        p = next(p for p in cls.decl if p.bounds is not None)
        out[p.name] = float(p.default) * 1.1 if p.default else 0.5 * (p.bounds[0] + p.bounds[1])
    return out


@pytest.mark.parametrize("name", LOOP_CONTROLLERS)
def test_loop_controller_deployment_round_trip(name, tmp_path):
    from objectives.control.objective import ClosedLoopObjective

    obj0 = ClosedLoopObjective.from_config({**LOOP_OBJECTIVE, "controller": name})
    choice = next((p for p in obj0.decl if p.choices), None)
    fixed = {choice.name: next(c for c in choice.choices if c != choice.default)} if choice else {"u_max": 50.0}
    objective = {**LOOP_OBJECTIVE, "controller": name, "fixed": fixed}
    run_dir = _tiny_run(tmp_path, objective)
    obj = ClosedLoopObjective.from_config(objective)

    dep = _check_controller_exports(run_dir, tmp_path, obj, name, fixed)
    assert dep.sample_rate_hz == pytest.approx(1.0 / LOOP_OBJECTIVE["period_s"])
    assert "plant" in dep.scoring and "scenario" in dep.scoring  # the simulation only served scoring


@pytest.mark.parametrize("name", [pytest.param(n, marks=pytest.mark.slow) if n == "flc" else n
                                  for n in WMP_CONTROLLERS])
@pytest.mark.slow
def test_controller_deployment_round_trip(name, tmp_path):
    from objectives.control.controllers import get_controller
    from objectives.control.objective import ClosedLoopObjective

    cls = get_controller(name)
    fixed = _controller_fixed(cls)
    objective = {"kind": "closed_loop", "controller": name, "profile": "thesis_2s", "duration_s": 2.0,
                 "requirements": None, "fixed": fixed}
    run_dir = _tiny_run(tmp_path, objective)
    obj = ClosedLoopObjective.from_config(objective)

    dep = _check_controller_exports(run_dir, tmp_path, obj, name, fixed)
    assert dep.sample_rate_hz == pytest.approx(1.0 / obj.loop.plant.sensors.Ts_s)
    assert "profile" in dep.scoring and "cost" in dep.scoring  # the simulation only served scoring


def test_function_objective_deploys_its_point(tmp_path):
    run_dir = _tiny_run(tmp_path, {"kind": "function", "function": "sphere", "dim": 2})
    best = yaml.safe_load((run_dir / "best.yaml").read_text())
    dep = load_deployment(run_dir)
    assert dep.kind == "function" and dep.name == "sphere" and dep.values == best["params"]


# --- baselines that mean one thing ---------------------------------------------------------------
def test_both_ways_of_writing_a_fixed_value_give_the_same_defaults_baseline(tmp_path):
    """"Defaults" = the config's fixed values with the searched parameters at the objective's defaults,
    in ``tuner cv`` (cv.md) and ``tuner evaluate CONFIG``, whether a value is fixed under
    ``objective.fixed`` or ``parameters: {x: {fixed: v}}``; with ``init: truth`` the two differed."""
    from tuner.config import config_from_dict
    from tuner.cv import cross_validate, cv_texts

    data = [{"synthetic": {"generator": "bench6dof", "duration_s": 4.0, "rate_hz": 200.0, "seed": s}} for s in (1, 2)]
    obj = {"kind": "filter", "filter": "mahony", "data": data, "metric": "euler_rmse_mean"}
    search = {"Kp": {"low": 0.1, "high": 2.0, "scale": "log"}}
    base = {"name": "base", "seed": 1, "optimizer": {"method": "pso", "population": 3, "generations": 1},
            "parallel": {"backend": "serial"}}
    a = config_from_dict({**base, "objective": {**obj, "fixed": {"init": "truth", "rest_bias": True}},
                          "parameters": search}, base_dir=tmp_path)
    b = config_from_dict({**base, "objective": obj,
                          "parameters": {**search, "init": {"fixed": "truth"}, "rest_bias": True}}, base_dir=tmp_path)
    c = config_from_dict({**base, "objective": obj, "parameters": search}, base_dir=tmp_path)  # nothing fixed
    outs = [cross_validate(cfg, k=2, full=False) for cfg in (a, b, c)]
    da, db, dc = ([f.default_fitness for f in o.folds] for o in outs)
    assert da == db and all(math.isfinite(x) for x in da)
    assert da != dc  # the fixed values do count: the baseline is not the bare filter's defaults
    md, _ = cv_texts(outs[0])
    assert "searched parameters at the objective's defaults" in md
    cfgs = []
    for name, cfg in (("a", a), ("b", b)):
        p = tmp_path / f"{name}.yaml"
        p.write_text(yaml.safe_dump({k: v for k, v in cfg.raw.items()}))
        cfgs.append(evaluate_target(p)["fitness"])
    assert cfgs[0] == cfgs[1] == pytest.approx(np.mean([outs[0].folds[0].default_fitness,
                                                        outs[0].folds[1].default_fitness]), rel=1e-12)


# --- the record itself -----------------------------------------------------------------------------
def test_deployment_doc_round_trip_and_bad_input():
    dep = Deployment("filter", "madgwick", {"beta": 0.1, "variant": "paper", "gate": math.inf},
                     units={"beta": "rad/s"}, sources={"beta": "searched", "variant": "default", "gate": "fixed"},
                     choices={"variant": ["paper", "original_c"]}, scoring={"init": "truth"}, sample_rate_hz=100.0,
                     notes=("starts from accmag",))
    back = Deployment.from_doc(yaml.safe_load(yaml.safe_dump(dep.to_doc())))
    assert back == dep and back.names("searched") == ["beta"] and back.names("default") == ["variant"]
    with pytest.raises(ValueError, match=r"deployment.values: missing"):
        Deployment.from_doc({"kind": "filter"})
    with pytest.raises(ValueError, match=r"deployment.extra: unknown key"):
        Deployment.from_doc({"kind": "filter", "values": {}, "extra": 1})
    with pytest.raises(ValueError, match=r"sources.*'tuned'"):
        Deployment("filter", "x", {"a": 1}, sources={"a": "tuned"})
    with pytest.raises(ValueError, match=r"sample_rate_hz"):
        Deployment("filter", "x", {"a": 1}, sample_rate_hz=-1.0)


def test_older_run_without_deployment_is_rebuilt_and_a_malformed_one_is_an_error(tmp_path):
    run_dir = _tiny_run(tmp_path, {"kind": "filter", "filter": "madgwick", "data": [_data("madgwick")],
                                   "fixed": {"rest_bias": True}})
    recorded = load_deployment(run_dir)
    doc = yaml.safe_load((run_dir / "best.yaml").read_text())
    old = {k: v for k, v in doc.items() if k != "deployment"}  # best.yaml as older runs wrote it
    (run_dir / "best.yaml").write_text(yaml.safe_dump(old))
    assert load_deployment(run_dir).values == recorded.values
    assert yaml.safe_load(export(run_dir, "yaml"))["params"]["rest_bias"] is True
    (run_dir / "best.yaml").write_text(yaml.safe_dump({**old, "deployment": {"kind": "filter"}}))
    out = run_tuner("export", run_dir, "--format", "c")
    assert out.returncode == 2 and out.stderr.startswith("error: ") and "best.yaml" in out.stderr
    assert "deployment.values: missing" in out.stderr


def test_objective_q0_start_is_deployed_and_a_truth_q0_is_scoring_only():
    from objectives.attitude.objective import FilterObjective

    section = {"kind": "filter", "filter": "madgwick", "data": [_data("madgwick")]}
    broad = FilterObjective.from_config({**section, "q0": "broad"}).deployment({"beta": 0.2})
    assert broad.values["init"] == "broad" and broad.sources["init"] == "fixed" and "init" not in broad.scoring
    truth = FilterObjective.from_config({**section, "q0": "truth"})
    dep = truth.deployment({"beta": 0.2})
    assert dep.values["init"] == "accmag" and dep.scoring["init"] == "truth" and dep.notes
    assert truth.build({"beta": 0.2}).values == dep.values


def test_the_builder_derives_sources_and_annotations_from_the_declaration():
    from tuner.deployment import build_deployment
    from tuner.params import Param, ParamSet

    decl = ParamSet("toy", (Param("gain", 1.0, (0.1, 10.0), unit="1/s", doc="loop gain"),
                            Param("mode", "fast", choices=("fast", "slow", "truth")),
                            Param("taps", 3, doc="filter length")))
    dep = build_deployment("toy_kind", "toy", {"gain": np.float64(2.5), "mode": "slow", "taps": np.int64(3)},
                           searched={"gain"}, fixed={"mode"}, decl=decl, scoring={"data": [np.float32(0.5)]},
                           sample_rate_hz=np.float64(100.0), notes=["starts at rest"], sources={"taps": "fixed"},
                           choices={"mode": ["fast", "slow"]})
    assert dep == Deployment("toy_kind", "toy", {"gain": 2.5, "mode": "slow", "taps": 3}, units={"gain": "1/s"},
                             docs={"gain": "loop gain", "taps": "filter length"},
                             sources={"gain": "searched", "mode": "fixed", "taps": "fixed"},
                             choices={"mode": ["fast", "slow"]}, scoring={"data": [0.5]}, sample_rate_hz=100.0,
                             notes=("starts at rest",))
    assert type(dep.values["gain"]) is float and type(dep.values["taps"]) is int  # YAML-native, as best.yaml holds it
    assert Deployment.from_doc(dep.to_doc()) == dep
    with pytest.raises(ValueError, match=r"deployment.values.mode: 'truth' is not one of its choices"):
        build_deployment("toy_kind", "toy", {"mode": "truth"}, decl=decl, choices={"mode": ["fast", "slow"]})


@pytest.mark.parametrize("section", [
    {"kind": "filter", "filter": "mahony", "data": [{"synthetic": {"generator": "bench6dof", "duration_s": 4,
                                                                   "seed": 1}}]},
    {"kind": "closed_loop", "controller": "pid"},
    {"kind": "function", "function": "sphere", "dim": 2},
    {"kind": "python", "callable": "json:dumps"},
])
def test_every_producer_returns_the_typed_deployment(section):
    obj = REGISTRY.build(section)
    params = {k: v for k, v in (obj.default_params() if hasattr(obj, "default_params") else {"x0": 0.5,
                                                                                           "x1": 1.0}).items()}
    dep = obj.deployment(params)
    assert isinstance(dep, Deployment) and dep.kind == section["kind"] and dep.values
    assert set(dep.sources) == set(dep.values) and Deployment.from_doc(dep.to_doc()) == dep
