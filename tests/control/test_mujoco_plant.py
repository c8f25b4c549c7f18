"""MuJoCo plants (objectives/control/plants/mujoco): the plant from MJCF/URDF with its names, the compiled loop
against a Python loop through MuJoCo's bindings, the linearisation against finite differences and the rigid-body
cart-pole, the LQR against python-control, uncertainty, threads, MuJoCo's warnings. Skipped without mujoco."""

import ctypes
import math
import pathlib

import numpy as np
import pytest

mujoco = pytest.importorskip("mujoco")

from objectives.control.objective import ClosedLoopObjective  # noqa: E402
from objectives.control.plants.mujoco.capi import capi, quiet_warnings  # noqa: E402
from objectives.control.plants.mujoco.controllers import LinearizedLQR, lqr_gain  # noqa: E402
from objectives.control.plants.mujoco.linearize import period_model  # noqa: E402
from objectives.control.plants.mujoco.model import mujoco_from_spec  # noqa: E402
from objectives.control.plants.mujoco.uncertainty import aggregation_from_spec, over_models  # noqa: E402
from tests.reference.loop_reference import pid_reference  # noqa: E402
from tests.reference.mujoco_reference import euler_zyx, mujoco_loop_reference, state_reader  # noqa: E402

ROOT = pathlib.Path(__file__).resolve().parents[2]
EXAMPLES = ROOT / "configs" / "examples"
MODELS = EXAMPLES / "mujoco"


def objective(plant, controller, **settings):
    section = {"kind": "closed_loop", "plant": plant, "controller": controller, **settings}
    return ClosedLoopObjective.from_config(section, base_dir=EXAMPLES)


CARTPOLE = {"mujoco": "mujoco/cartpole.xml", "keyframe": "upright", "outputs": ["cart_position", "hinge"]}
ARM = {"mujoco": "mujoco/arm2.xml", "keyframe": "hanging"}
ARM_GAINS = {"shoulder_K": 200.0, "shoulder_Ti_s": 0.5, "shoulder_Td_s": 0.05, "elbow_K": 80.0, "elbow_Ti_s": 0.4,
             "elbow_Td_s": 0.03, "elbow_b": 0.7, "elbow_c": 0.2}


# --- item 1: the plant ------------------------------------------------------------------------------------
def test_plant_names_sizes_keyframe_and_ranges():
    p = mujoco_from_spec({**CARTPOLE, "state_joints": ["slider", {"joint": "hinge", "position": True}]}, 0.004,
                         EXAMPLES)
    assert (p.n_inputs, p.n_outputs, p.n_states, p.n_sub) == (1, 2, 4, 2)
    assert p.input_names == ["push"] and p.output_names == ["cart_position", "hinge"]
    assert p.state_names == ["slider", "hinge", "slider_vel", "hinge_vel"]
    assert np.array_equal(p.ulim, [[-20.0, 20.0]]) and p.timestep_s == 0.002
    assert np.array_equal(p.out_state, [0, 1])  # a jointpos sensor and a joint are state entries
    q = mujoco_from_spec({**CARTPOLE, "ctrlrange": {"push": [-5, 5]}, "qpos": [0.2, 0.05], "timestep_s": 0.001},
                         0.004, EXAMPLES)
    assert np.array_equal(q.ulim, [[-5.0, 5.0]]) and np.array_equal(q.mj.actuator_ctrlrange[0], [-5, 5])
    assert q.n_sub == 4 and np.array_equal(q.qpos_op, [0.2, 0.05])
    assert q.mj.opt.disableflags & int(mujoco.mjtDisableBit.mjDSBL_AUTORESET)


def test_outputs_read_what_mujoco_says():
    """Sensor, joint position and velocity, and a body's pitch read from the data, against the data itself."""
    spec = {**CARTPOLE, "outputs": ["cart_position", "pole_angle", {"joint_velocity": "hinge"},
                                    {"body": "pole", "angle": "pitch"}, {"body": "pole", "angle": "roll"}]}
    p = mujoco_from_spec(spec, 0.002, EXAMPLES)
    d = p.new_data()
    d.qpos[:], d.qvel[:] = [0.3, 0.4], [0.1, -0.7]
    y = p.output_values(d)
    assert y[0] == d.sensordata[0] == d.qpos[0] and y[1] == d.qpos[1] and y[2] == d.qvel[1]
    assert y[3] == pytest.approx(0.4, abs=1e-12)  # a hinge about y turns the pole's pitch
    assert y[3] == pytest.approx(euler_zyx(d.xquat[2])[1], abs=1e-15) and abs(y[4]) < 1e-12


@pytest.mark.slow
def test_urdf_compiled_by_mujoco_with_motors_added(tmp_path):
    urdf = tmp_path / "arm.urdf"
    link = ('<link name="{n}"><inertial><origin xyz="0 0 -0.2"/><mass value="1.0"/><inertia ixx="0.02" iyy="0.02" '
            'izz="0.001" ixy="0" ixz="0" iyz="0"/></inertial></link>')
    urdf.write_text('<robot name="arm">' + link.format(n="base") + link.format(n="l1") + link.format(n="l2")
                    + '<joint name="j1" type="revolute"><parent link="base"/><child link="l1"/><axis xyz="0 1 0"/>'
                      '<limit lower="-3" upper="3" effort="50" velocity="10"/></joint>'
                      '<joint name="j2" type="revolute"><parent link="l1"/><child link="l2"/>'
                      '<origin xyz="0 0 -0.4"/><axis xyz="0 1 0"/><limit lower="-3" upper="3" effort="50" '
                      'velocity="10"/></joint></robot>')
    obj = ClosedLoopObjective.from_config({
        "kind": "closed_loop", "plant": {"mujoco": "arm.urdf", "motors": ["j1", "j2"], "ctrlrange": {"j1": [-30, 30]}},
        "controller": "joint_pid", "period_s": 0.002,
        "scenario": {"duration_s": 0.4, "reference": {"j1": [{"t": 0.05, "value": 0.3}]}}}, base_dir=tmp_path)
    assert obj.loop.plant.input_names == ["j1", "j2"] and obj.loop.plant.output_names == ["j1", "j2"]
    ev = obj({"j1_K": 100.0, "j1_Td_s": 0.05, "j2_K": 100.0, "j2_Td_s": 0.05})
    assert ev.status == "ok" and ev.metrics["peak_u"] <= 30.0 + 1e-12


# --- the compiled loop against the Python loop ------------------------------------------------------------
def test_joint_pids_with_noise_and_delay_equal_the_python_loop():
    obj = objective(ARM, "joint_pid", period_s=0.004,
                    scenario={"duration_s": 1.5, "reference": {"shoulder": [{"t": 0.1, "value": 0.9}],
                                                                "elbow": [{"t": 0.4, "value": -0.5}]}},
                    sensor={"noise_std": {"shoulder": 0.002, "elbow": 0.004}, "delay_s": 0.008, "seed": 3})
    loop, v = obj.loop, obj.values(ARM_GAINS)
    sim = obj.simulate(ARM_GAINS)["runs"][0]
    p = loop.plant
    pids = [pid_reference(v[f"{n}_K"], v[f"{n}_Ti_s"], v[f"{n}_Td_s"], v["N"], v[f"{n}_b"], v[f"{n}_c"], 0.004,
                          umin=p.ulim[i, 0], umax=p.ulim[i, 1]) for i, n in enumerate(("shoulder", "elbow"))]
    y, u = mujoco_loop_reference(
        p.mj, p.qpos_op, p.qvel_op, p.act_op, p.ctrl_op, lambda d: d.qpos.copy(),
        state_reader(p.mj, p.qpos_op, p.qvel_op, p.pdofs, p.vdofs),
        lambda r, meas: [pids[0](r[0], meas[0]), pids[1](r[1], meas[1])], [0, 1], p.ulim, loop._sc.r,
        loop._noise, 2, p.n_sub)
    assert np.abs(sim["y"] - y).max() < 1e-9 and np.abs(sim["u"] - u).max() < 1e-7
    assert np.abs(u).max() > 1.0 and np.any(np.abs(u) >= p.ulim[:, 1] - 1e-9)  # the PIDs act and saturate


def test_lqr_loop_equals_the_python_loop():
    obj = objective(CARTPOLE, "lqr_fd", period_s=0.004,
                    scenario={"duration_s": 2.0, "reference": {"cart_position": [{"t": 0.2, "value": 0.3}]},
                              "initial": {"hinge": 0.05}},
                    sensor={"noise_std": 0.001, "seed": 1})
    params = {"q_slider": 10.0, "r_push": 0.1}
    sim, p = obj.simulate(params)["runs"][0], obj.loop.plant
    g = LinearizedLQR.gains(obj.coeffs(params))

    def lqr(r, x):
        rd = r[g["tracked"]] - g["r_op"]
        return g["u_op"] + g["Nu"] @ rd - g["K"] @ (x - g["Nx"] @ rd)

    qpos0 = p.qpos_op + obj.loop._sc.qpos_offset
    y, u = mujoco_loop_reference(p.mj, qpos0, p.qvel_op, p.act_op, p.ctrl_op, lambda d: d.qpos.copy(),
                                 state_reader(p.mj, p.qpos_op, p.qvel_op, p.pdofs, p.vdofs), lqr, [0], p.ulim,
                                 obj.loop._sc.r, obj.loop._noise, 0, p.n_sub, state_feedback=True)
    assert np.abs(sim["y"] - y).max() < 1e-9 and np.abs(sim["u"] - u).max() < 1e-7
    assert abs(sim["y"][-1, 0] - 0.3) < 0.02  # the cart reached its set point, the pole upright


def test_no_python_per_physics_step(monkeypatch):
    """The compiled loop steps MuJoCo through its C functions: the bindings' step functions are not called."""
    obj = objective(CARTPOLE, "lqr_fd", period_s=0.002, scenario={"duration_s": 0.5, "initial": {"hinge": 0.05}})
    before = obj({})

    def forbidden(*args, **kwargs):
        raise AssertionError("a Python call per physics step")

    for name in ("mj_step", "mj_step1", "mj_step2", "mj_forward"):
        monkeypatch.setattr(mujoco, name, forbidden)
    after = obj({})
    assert after.status == "ok" and after.fitness == before.fitness


# --- item 2: controllers ----------------------------------------------------------------------------------
def test_period_model_equals_finite_differences_of_the_held_input():
    """Ad, Bd over 3 engine steps with the input held, against central differences through the bindings."""
    p = mujoco_from_spec({**CARTPOLE}, 0.006, EXAMPLES)
    ad, bd, residual = period_model(p)
    assert np.abs(residual).max() < 1e-12  # the keyframe is an equilibrium

    def advance(x, u):
        d = p.new_data()
        d.qpos[:], d.qvel[:] = p.qpos_op + x[:2], p.qvel_op + x[2:]
        d.ctrl[0] = u
        mujoco.mj_step(p.mj, d, p.n_sub)
        return np.r_[d.qpos - p.qpos_op, d.qvel - p.qvel_op]

    eps = 1e-6
    a_ref = np.column_stack([(advance(e * eps, 0.0) - advance(-e * eps, 0.0)) / (2 * eps) for e in np.eye(4)])
    b_ref = (advance(np.zeros(4), eps) - advance(np.zeros(4), -eps)) / (2 * eps)
    assert np.abs(ad - a_ref).max() < 1e-6 and np.abs(bd[:, 0] - b_ref).max() < 1e-6


@pytest.mark.parametrize("mass_scale", [1.0, 1.2])
def test_linearisation_is_the_rigid_body_cart_pole(mass_scale):
    """MuJoCo's period model against the textbook cart-pole (Lagrange, with MuJoCo's masses, inertia and
    damping), discretised exactly: equal up to the integrator's O((h |lambda|)^2) per period."""
    import scipy.linalg

    spec = {**CARTPOLE, "parameters": {"body.pole.mass": 0.1 * mass_scale}}
    p = mujoco_from_spec(spec, 0.002, EXAMPLES)
    m = p.mj
    big_m, mp = m.body_mass[1], m.body_mass[2]
    assert mp == pytest.approx(0.1 * mass_scale)
    lc = m.body_ipos[2][2]
    rot = np.zeros(9)
    mujoco.mju_quat2Mat(rot, m.body_iquat[2])
    rot = rot.reshape(3, 3)
    iyy = (rot @ np.diag(m.body_inertia[2]) @ rot.T)[1, 1]
    bx, bt = m.dof_damping
    mass = np.array([[big_m + mp, mp * lc], [mp * lc, iyy + mp * lc * lc]])
    stiff = np.array([[0.0, 0.0], [0.0, -mp * 9.81 * lc]])
    minv = np.linalg.inv(mass)
    a = np.block([[np.zeros((2, 2)), np.eye(2)], [-minv @ stiff, -minv @ np.diag([bx, bt])]])
    b = np.r_[np.zeros(2), minv @ [1.0, 0.0]][:, None]
    h = p.period_s
    e = scipy.linalg.expm(np.block([[a, b], [np.zeros((1, 5))]]) * h)
    ad, bd = p.design_model()
    tol = 3 * (h * np.max(np.abs(np.linalg.eigvals(a)))) ** 2
    assert np.abs(ad - e[:4, :4]).max() < tol and np.abs(bd - e[:4, 4:]).max() < tol * np.abs(b).max()


def test_lqr_gain_equals_python_control_dlqr():
    import control

    p = mujoco_from_spec({**CARTPOLE}, 0.004, EXAMPLES)
    ad, bd = p.design_model()
    q, r = np.diag([3.0, 20.0, 0.5, 0.1]), np.diag([0.05])
    k_ref, _, _ = control.dlqr(ad, bd, q, r)
    assert np.abs(lqr_gain(ad, bd, q, r) - k_ref).max() < 1e-8 * np.abs(k_ref).max()
    with pytest.raises(ValueError, match="no stabilising solution|does not stabilise"):
        lqr_gain(np.diag([1.5, 0.5]), np.array([[0.0], [1.0]]), np.eye(2), np.eye(1))  # an unstable mode out of reach


def test_joint_pid_coefficients_are_the_generic_pid_blocks():
    from objectives.control.plants.controllers import pid_coeffs

    obj = objective(ARM, "joint_pid", period_s=0.002, scenario={"duration_s": 0.1})
    cp = obj.coeffs(ARM_GAINS)
    v = obj.values(ARM_GAINS)
    assert cp[0] == 2 and list(cp[1:3]) == [0, 0] and list(cp[13:15]) == [1, 1]
    ref = pid_coeffs(200.0, 0.5, 0.05, 0.002, {**v, "b": 1.0, "c": 0.0, "u_min": -40.0, "u_max": 40.0})
    assert np.array_equal(cp[3:13], ref)


def test_set_points_only_where_the_linearisation_holds_them():
    obj = objective(CARTPOLE, "lqr_fd", period_s=0.004,
                    scenario={"duration_s": 0.5, "reference": {"cart_position": [{"t": 0.1, "value": 0.3}]}})
    g = LinearizedLQR.gains(obj.coeffs({}))
    assert np.allclose(g["Nx"][:, 0], [1, 0, 0, 0], atol=1e-9) and abs(g["Nu"][0, 0]) < 1e-9
    with pytest.raises(ValueError, match=r"objective.scenario.reference: no steady state .* \['hinge'\]"):
        objective(CARTPOLE, "lqr_fd", period_s=0.004,
                  scenario={"duration_s": 0.5, "reference": {"hinge": [{"t": 0.1, "value": 0.2}]}})


def test_saturation_from_ctrlrange_and_its_override():
    for over, lim in ((None, 20.0), ({"push": [-5, 5]}, 5.0)):
        spec = {**CARTPOLE, **({"ctrlrange": over} if over else {})}
        obj = objective(spec, "lqr_fd", period_s=0.002,
                        scenario={"duration_s": 1.0, "reference": {"cart_position": [{"t": 0.0, "value": 2.0}]},
                                  "initial": {"hinge": 0.05}})
        u = obj.simulate({"q_slider": 1000.0, "r_push": 0.001})["runs"][0]["u"]
        assert np.abs(u).max() == pytest.approx(lim)


# --- item 3: uncertainty ----------------------------------------------------------------------------------
def test_perturbed_plant_equals_the_spec_with_parameters():
    values = {"body.pole.mass": 0.13, "joint.hinge.damping": 0.02, "actuator.push.gain": 1.1,
              "body.cart.iyy": 0.01}
    base = mujoco_from_spec(CARTPOLE, 0.002, EXAMPLES)
    a = base.with_parameters(values)
    b = mujoco_from_spec({**CARTPOLE, "parameters": values}, 0.002, EXAMPLES)
    for field in ("body_mass", "body_inertia", "dof_damping", "actuator_gainprm", "body_subtreemass",
                  "dof_invweight0"):
        assert np.array_equal(getattr(a.mj, field), getattr(b.mj, field)), field
    assert a.named_parameters()["body.pole.mass"] == 0.13 and base.named_parameters()["body.pole.mass"] == 0.1
    d1, d2 = a.new_data(), b.new_data()
    d1.ctrl[0] = d2.ctrl[0] = 3.0
    mujoco.mj_step(a.mj, d1, 50)
    mujoco.mj_step(b.mj, d2, 50)
    assert np.array_equal(d1.qpos, d2.qpos)
    with pytest.raises(ValueError, match=r"objective.plant.parameters.body.nobody.mass: not a named parameter"):
        base.with_parameters({"body.nobody.mass": 1.0})


def test_actuator_gain_scales_the_force_law():
    base = mujoco_from_spec(CARTPOLE, 0.002, EXAMPLES)
    acc = []
    for p in (base, base.with_parameters({"actuator.push.gain": 2.5})):
        d = p.new_data()
        d.ctrl[0] = 4.0
        mujoco.mj_forward(p.mj, d)
        acc.append(d.qfrc_actuator[0])
    assert acc[1] == pytest.approx(2.5 * acc[0], rel=1e-12)


UNC = {"parameters": {"body.cart.mass": {"rel": 0.2}, "body.pole.mass": [0.08, 0.12], "sensor.delay_s": [0.0, 0.004]},
       "tune": {"samples": 3, "seed": 2}, "validate": {"samples": 5, "seed": 3}}


def test_tuning_and_held_out_sets():
    obj = objective(CARTPOLE, "lqr_fd", period_s=0.002, scenario={"duration_s": 0.2}, uncertainty=UNC)
    loop = obj.loop
    assert len(loop.cases) == 1 + 8 + 3 and loop.cases[0].values == {}
    corners = [c.values for c in loop.cases[1:9]]
    assert {round(c["body.cart.mass"], 12) for c in corners} == {0.8, 1.2}
    assert {c["body.pole.mass"] for c in corners} == {0.08, 0.12}
    assert {c.delay_n for c in loop.cases[1:9]} == {0, 2}
    again = objective(CARTPOLE, "lqr_fd", period_s=0.002, scenario={"duration_s": 0.2}, uncertainty=UNC).loop
    assert [c.values for c in again.cases] == [c.values for c in loop.cases]
    held = loop._unc.held_out_set()
    assert len(held) == 5 and not {tuple(c.values.values()) for c in held} & {tuple(c.values.values())
                                                                              for c in loop.cases}
    assert loop.plants[1].mj.body_mass[1] == pytest.approx(loop.cases[1].values["body.cart.mass"])


def test_a_models_delay_is_the_sensor_delay():
    """The corner with a 2-period delay runs as the nominal job with sensor.delay_s = 2 periods."""
    unc = {"parameters": {"sensor.delay_s": [0.0, 0.004]}, "tune": {"corners": True, "samples": 0}}
    sc = {"duration_s": 1.0, "initial": {"hinge": 0.05}}
    a = objective(CARTPOLE, "lqr_fd", period_s=0.002, scenario=sc, uncertainty=unc)
    b = objective(CARTPOLE, "lqr_fd", period_s=0.002, scenario=sc, sensor={"delay_s": 0.004})
    ra, rb = a.simulate({})["runs"], b.simulate({})["runs"][0]
    assert [c.delay_n for c in a.loop.cases] == [0, 0, 2] and np.array_equal(ra[2]["u"], rb["u"])
    assert not np.array_equal(ra[0]["u"], rb["u"])


def test_aggregates_over_models_are_the_shared_forms():
    c = np.array([1.0, 4.0, 2.0, 3.0, 10.0])
    agg = {f: aggregation_from_spec({"models": f}) for f in ("mean", "worst")}
    assert over_models(c, agg["mean"]) == 4.0 and over_models(c, agg["worst"]) == 10.0 and over_models(c, None) == 4.0
    assert over_models(c, aggregation_from_spec({"models": {"cvar": 0.4}})) == pytest.approx(7.0)
    assert over_models(c, aggregation_from_spec({"models": {"cvar": 0.01}})) == 10.0


def test_an_evaluation_fails_on_any_model_and_names_it():
    unc = {"parameters": {"actuator.push.gain": [0.05, 1.0]}, "tune": {"samples": 0}}
    obj = objective(CARTPOLE, "lqr_fd", period_s=0.002, uncertainty=unc,
                    scenario={"duration_s": 2.0, "initial": {"hinge": 0.3}, "limits": {"hinge": 0.6}})
    ev = obj({})
    assert ev.status == "failed" and ev.error.startswith("corner -: hinge beyond its limit at t=")
    assert ev.error.endswith("(failed on 1 of 3 models)")


# --- item 4: threads --------------------------------------------------------------------------------------
def test_threads_equal_serial_bit_for_bit():
    obj = objective(CARTPOLE, "lqr_fd", period_s=0.002, uncertainty=UNC, sensor={"noise_std": 0.001},
                    scenario={"duration_s": 0.6, "reference": {"cart_position": [{"t": 0.1, "value": 0.2}]},
                              "initial": {"hinge": 0.05}, "limits": {"hinge": 0.5}})
    rng = np.random.default_rng(0)
    cands = [{"q_slider": float(10 ** rng.uniform(-2, 3)), "q_hinge": float(10 ** rng.uniform(-2, 3)),
              "r_push": float(10 ** rng.uniform(-3, 1))} for _ in range(5)]
    cands.append({"q_slider": 1e-3, "q_hinge": 1e-3, "q_slider_vel": 1e-3, "q_hinge_vel": 1e-3, "r_push": 1e3})
    serial = [obj(c) for c in cands]
    for n in (1, 2, 3):
        batch = obj.evaluate_batch(cands, n)
        for s, b in zip(serial, batch):
            assert (s.status, s.error) == (b.status, b.error)
            assert s.fitness == b.fitness and s.metrics == pytest.approx(b.metrics, nan_ok=True, rel=0, abs=0)


# --- item 7: MuJoCo's instability, quietly ----------------------------------------------------------------
def test_an_unstable_run_fails_with_mujocos_text_and_writes_no_log(tmp_path, monkeypatch, capfd):
    monkeypatch.chdir(tmp_path)
    xml = tmp_path / "stiff.xml"
    xml.write_text('<mujoco><option timestep="0.01"/><worldbody><body name="b"><joint name="j" type="slide" '
                   'axis="1 0 0"/><geom size="0.1" mass="0.001"/></body></worldbody><actuator><motor name="m" '
                   'joint="j"/></actuator></mujoco>')
    obj = ClosedLoopObjective.from_config({"kind": "closed_loop", "plant": {"mujoco": str(xml)},
                                           "controller": "joint_pid", "period_s": 0.01,
                                           "scenario": {"duration_s": 2.0, "reference": {"j": [{"t": 0, "value": 1}]}}})
    ev = obj({"j_K": 1e3, "j_Ti_s": 1e2, "j_Td_s": 1.0})  # a derivative gain far beyond the step's stability
    assert ev.status == "failed" and ("MuJoCo: Nan, Inf or huge value" in ev.error or "diverged" in ev.error)
    assert not (tmp_path / "MUJOCO_LOG.TXT").exists() and "WARNING" not in capfd.readouterr().out


def test_quiet_warnings_restores_the_handler():
    slot = ctypes.c_void_p.in_dll(capi().lib, "mju_user_warning")
    before = slot.value
    with quiet_warnings():
        inside = slot.value
        with quiet_warnings():
            assert slot.value == inside
        assert slot.value == inside
    assert inside not in (None, 0) and slot.value == before


def test_describe_and_catalog(capsys):
    from tuner.cli import main

    assert main(["describe", "plant"]) == 0
    assert "mujoco" in capsys.readouterr().out
    for name, key in (("joint_pid", "joint1_Ti_s"), ("lqr_fd", "q_joint1_vel")):
        assert main(["describe", name]) == 0
        assert key in capsys.readouterr().out
    assert math.isfinite(objective(CARTPOLE, "lqr_fd", period_s=0.002, scenario={"duration_s": 0.1})({}).fitness)
