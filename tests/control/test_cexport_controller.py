"""The generic loop's controllers as C99 (objectives/control/plants/cexport.py): the compiled C closes the loop
on the same trajectory as the numba kernel (states, outputs and commands within 1e-9 in double) for every
controller with a C port, with saturation and anti-windup active, 2-DOF weights, a rate limit, a quantum, an
input delay, noise and loads, on LTI and Python plants; the float build stays close; the struct is the
declaration's; `tuner export --format c-controller` and `tuner verify-c` on a finished run; bad input is one
error line."""

from __future__ import annotations

import math
import re
import subprocess
from pathlib import Path

import numpy as np
import pytest
import yaml

from objectives.control.objective import ClosedLoopObjective
from objectives.control.plants.cexport import CController, c_controller_names, c_trace, render_c_controller
from objectives.csource import STRICT_FLAGS, compile_shared, find_compiler
from tests.conftest import readme_c_block, run_tuner

ROOT = Path(__file__).resolve().parents[2]
needs_cc = pytest.mark.skipif(find_compiler() is None, reason="no C compiler (cc, gcc or clang) on the PATH")

MOTOR = {"tf": {"num": [0.01], "den": [0.005, 0.06, 0.1001]}, "delay_s": 0.004}
MOTOR_POS = {"ss": {"A": [[0, 1], [0, -5.0]], "B": [[0], [5.0]], "C": [[1, 0], [0, 1]], "D": [[0], [0]]},
             "output": 0, "inner_output": 1}
OSC = {"ss": {"A": [[0, 1], [-2, -0.5]], "B": [[0], [1]], "C": [[1, 0]], "D": [[0]]}}
STEP_LOAD = {"duration_s": 2.0, "reference": [{"t": 0.1, "value": 1.0}], "load": [{"t": 1.2, "value": 3.0}]}


def _obj(plant, controller, **kw):
    sec = {"kind": "closed_loop", "plant": plant, "controller": controller, "period_s": kw.pop("period_s", 0.002),
           "scenario": kw.pop("scenario", STEP_LOAD)}
    sec.update(kw)
    return ClosedLoopObjective.from_config(sec, ROOT / "configs" / "examples")


#: name -> objective: each controller with a C port, in the situations its C must reproduce
CASES = {
    "pid2dof, back-calculation saturated, b c != 1, rate limit, quanta, delay, noise": lambda: _obj(
        MOTOR, "pid2dof", fixed={"K": 60.0, "Ti_s": 0.3, "Td_s": 0.01, "b": 0.6, "c": 0.4},
        actuator={"u_min": -24, "u_max": 24, "rate_limit": 2000.0, "quantum": 0.01},
        sensor={"noise_std": 0.002, "seed": 3, "quantum": 0.001}),
    "pid2dof, clamping saturated": lambda: _obj(
        MOTOR, "pid2dof", fixed={"K": 60.0, "Ti_s": 0.3, "antiwindup": "clamp"}, actuator={"u_min": -24, "u_max": 24}),
    "pid2dof_par with derivative": lambda: _obj(
        MOTOR, "pid2dof_par", fixed={"Kp": 40.0, "Ki": 100.0, "Kd": 0.5, "b": 0.8, "c": 0.5},
        actuator={"u_min": -30, "u_max": 30}),
    "pid_cascade, both blocks limited": lambda: _obj(
        MOTOR_POS, "pid_cascade", period_s=0.005, actuator={"u_min": -1.0, "u_max": 1.0},
        fixed={"K_o": 4.0, "Ti_o_s": 5.0, "Td_o_s": 0.05, "K_i": 0.5, "Ti_i_s": 0.2, "N": 10.0, "c": 1.0, "b": 0.5,
               "r_i_min": -2.0, "r_i_max": 2.0},
        scenario={"duration_s": 6.0, "reference": [{"t": 0.0, "value": 1.0}], "load": [{"t": 4.0, "value": 0.3}]}),
    "lqr_sf saturated, state noise": lambda: _obj(
        OSC, "lqr_sf", period_s=0.01, fixed={"q1": 50.0, "q2": 1.0, "r1": 0.1}, actuator={"u_min": -3.0, "u_max": 3.0},
        sensor={"noise_std": [0.001, 0.002], "seed": 1}),
    "lqr_sf on Python dynamics (cart-pole)": lambda: ClosedLoopObjective.from_config(
        yaml.safe_load((ROOT / "configs/examples/cartpole_lqr.yaml").read_text())["objective"],
        ROOT / "configs" / "examples"),
}


def _compiled(obj, tmp_path, precision="double"):
    loop = obj.loop
    files = render_c_controller(loop.ctrl, obj.values({}), loop.plant, loop.realism, precision=precision,
                                prefix="T")
    return CController(compile_shared(files, tmp_path, ("-O2",)), "T", precision), files


def _kernel_and_c(obj, ctl):
    loop = obj.loop
    runner = loop._runner
    py = loop.simulate({})
    c = c_trace(loop.plant, runner.sigs[0], runner.opt[0], ctl)
    return py, c


@needs_cc
@pytest.mark.parametrize("case", [pytest.param(c, marks=pytest.mark.slow) if "Python" in c else c for c in CASES])
def test_the_compiled_controller_closes_the_loop_like_the_kernel(case, tmp_path):
    obj = CASES[case]()
    ctl, _ = _compiled(obj, tmp_path)
    py, c = _kernel_and_c(obj, ctl)
    assert py["status"] == c["status"] == 0 and c["n_done"] == py["t"].size
    for k in ("x", "y", "u"):
        scale = max(1.0, float(np.max(np.abs(py[k]))))
        assert np.max(np.abs(py[k] - c[k])) <= 1e-9 * scale, k
    real = obj.loop.realism
    if math.isfinite(real.u_max) and "cart-pole" not in case:  # the case exercises the limits it names
        assert np.any(np.abs(c["u"][:, 0]) >= min(-real.u_min, real.u_max) - 1e-9)


@needs_cc
def test_anti_windup_is_what_the_c_reproduces(tmp_path):
    """The saturated case differs between back-calculation, clamping and none (so the equality above is the
    anti-windup's, not a loop that never integrates while saturated), and C equals the kernel in each."""
    outs = {}
    for aw in ("backcalc", "clamp", "none"):
        obj = _obj(MOTOR, "pid2dof", fixed={"K": 60.0, "Ti_s": 0.3, "antiwindup": aw},
                   actuator={"u_min": -24, "u_max": 24})
        ctl, _ = _compiled(obj, tmp_path / aw)
        py, c = _kernel_and_c(obj, ctl)
        assert np.max(np.abs(py["y"] - c["y"])) <= 1e-9
        outs[aw] = c["y"][:, 0]
    assert np.max(np.abs(outs["backcalc"] - outs["none"])) > 1e-2
    assert np.max(np.abs(outs["clamp"] - outs["none"])) > 1e-2


@needs_cc
@pytest.mark.parametrize("case", list(CASES)[::2])
def test_the_float_build_stays_close(case, tmp_path):
    """float arithmetic: the loop's cost within 1e-4 (relative) and the trajectories within 1e-3 of their
    scale (a command quantum may flip one step: that case is checked on its cost only)."""
    obj = CASES[case]()
    ctl, files = _compiled(obj, tmp_path, "float")
    assert "typedef float T_real;" in next(t for n, t in files.items() if n.endswith(".h"))
    py, c = _kernel_and_c(obj, ctl)
    assert c["status"] == 0
    if obj.loop.realism.u_quantum == 0:
        for k in ("x", "u"):
            assert np.max(np.abs(py[k] - c[k])) <= 1e-3 * max(1.0, float(np.max(np.abs(py[k])))), k
    e_py, e_c = (float(np.sum(np.abs(tr["y"][:, obj.loop.plant.output] - obj.loop.runner(obj.loop.models)
                                      .sigs[0][:, 0]))) for tr in (py, c))
    assert e_c == pytest.approx(e_py, rel=1e-4)


@needs_cc
def test_the_c_compiles_strictly_and_its_struct_is_the_declaration(tmp_path):
    """-std=c99 -Wall -Wextra -Werror -pedantic at -O0 and -O2, both precisions; PREFIX_params holds every
    declared value (a choice as its enum) and the actuator; a state feedback's gain instead of its weights."""
    cc = find_compiler()
    for name, case in (("pid", list(CASES)[0]), ("casc", list(CASES)[3]), ("sf", list(CASES)[4])):
        obj = CASES[case]()
        for precision in ("double", "float"):
            files = render_c_controller(obj.loop.ctrl, obj.values({}), obj.loop.plant, obj.loop.realism,
                                        precision=precision, prefix="X")
            for n, t in files.items():
                (tmp_path / n).write_text(t)
            for opt in ("-O0", "-O2"):
                res = subprocess.run([*cc, *STRICT_FLAGS, opt, "-c", "-o", str(tmp_path / "x.o"),
                                      str(tmp_path / "x.c")], capture_output=True, text=True)
                assert res.returncode == 0 and not res.stderr, (name, precision, opt, res.stderr)
        header = files["x.h"]
        fields = re.findall(r"^    X_real (\w+)(?:\[[^;]*)?; /\*", header, re.M) + \
            re.findall(r"^    int (\w+); /\*", header, re.M)
        decl = [p.name for p in obj.loop.ctrl.declaration_for(obj.loop.plant).params]
        if name == "sf":
            assert "K" in fields and "Nbar" in fields and not any(re.fullmatch(r"[qr]\d+", f) for f in fields)
            assert set(decl) - set(fields) == {p for p in decl if re.fullmatch(r"[qr]\d+", p)}
        else:
            assert set(decl) <= set(fields)
            assert "X_ANTIWINDUP_BACKCALC = 0" in header
        assert {"period_s", "act_u_min", "act_u_max", "act_rate_limit", "act_quantum"} <= set(fields)


def test_only_the_controllers_with_a_port_render():
    assert c_controller_names() == ["lqr_sf", "pid2dof", "pid2dof_par", "pid_cascade"]
    obj = _obj(MOTOR, "open_loop")
    with pytest.raises(ValueError, match=r"^objective.controller: 'open_loop' has no C port; the controllers with "
                                         r"one: lqr_sf, pid2dof"):
        obj.export_c({}, "double", "X", "")
    wmp = ClosedLoopObjective(plant="wmp", controller="pid")
    with pytest.raises(ValueError, match=r"^objective.controller: 'pid' \(plant wmp\) has no C port"):
        wmp.export_c({}, "double", "X", "")
    with pytest.raises(ValueError, match="precision must be 'double' or 'float'"):
        _obj(MOTOR, "pid2dof").export_c({}, "long double", "X", "")


# --- the command line on a finished run --------------------------------------------------------------------

def _tuner(*args, check=True):
    return run_tuner(*args, cwd=ROOT, check=check)


@pytest.fixture(scope="module")
def motor_run(tmp_path_factory):
    """configs/examples/dc_motor_firmware.yaml at a tiny budget."""
    run_dir = tmp_path_factory.mktemp("motor") / "run"
    _tuner("run", ROOT / "configs/examples/dc_motor_firmware.yaml", "--run-dir", run_dir, "-q", "--no-report",
           "--set", "optimizer.population=4", "--set", "optimizer.generations=2")
    return run_dir


@needs_cc
@pytest.mark.slow
def test_export_c_controller_compiles_with_the_readme_example(motor_run, tmp_path):
    out = _tuner("export", motor_run, "--format", "c-controller", "--prefix", "MOTOR", "--out", tmp_path)
    assert "motor.h" in out.stderr and "motor.c" in out.stderr
    header = (tmp_path / "motor.h").read_text()
    best = yaml.safe_load((motor_run / "best.yaml").read_text())
    for k, v in best["params"].items():
        assert f"{k}: {v!r}" in header  # the searched values, exactly
    assert "antiwindup: 'backcalc'" in header and "rate limit 6000.0" in header
    (tmp_path / "main.c").write_text(readme_c_block("controller-example"))
    exe = tmp_path / "main"
    res = subprocess.run([*find_compiler(), *STRICT_FLAGS, "-O2", "-o", str(exe), str(tmp_path / "main.c"),
                          str(tmp_path / "motor.c"), "-lm"], capture_output=True, text=True)
    assert res.returncode == 0 and not res.stderr, res.stderr
    y_end = float(subprocess.run([str(exe)], capture_output=True, text=True, check=True).stdout.split()[-1])
    assert y_end == pytest.approx(0.5, abs=0.02)  # the example's own plant reaches its set point


@needs_cc
@pytest.mark.slow
def test_verify_c_closes_the_loop_next_to_the_model(motor_run):
    out = _tuner("verify-c", motor_run)
    m = re.search(r"fitness model (\S+), C (\S+) \(C - model (\S+)\)", out.stdout)
    assert m and float(m.group(1)) == float(m.group(2)), out.stdout
    diffs = [float(x) for x in re.findall(r"max \|C - model\| (\S+)", out.stdout)]
    assert len(diffs) == 2 and max(diffs) <= 1e-9, out.stdout  # both scenarios
    out = _tuner("verify-c", motor_run, "--precision", "float")
    assert "(float, -O2)" in out.stdout


@pytest.mark.slow
def test_a_c_format_of_the_other_kind_is_one_error_line(motor_run):
    out = _tuner("export", motor_run, "--format", "c-filter", "--out", motor_run / "x", check=False)
    assert out.returncode == 2 and out.stderr.startswith("error:") and len(out.stderr.strip().splitlines()) == 1
    assert "config.yaml: objective: --format c-filter" in out.stderr and "use --format c-controller" in out.stderr
