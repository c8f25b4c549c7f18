"""The generic closed loop (objectives/control/plants) against independent references: closed-form
first-order responses, python-control's step/forced responses, dlqr and stability margins, and the
slow reference loop of tests/reference/loop_reference.py."""

import math
import pickle

import control
import numpy as np
import pytest

from objectives.control.objective import ClosedLoopObjective
from tests.reference.loop_reference import loop_reference, pid_reference


def _obj(plant, controller="open_loop", **kw):
    sec = {"kind": "closed_loop", "plant": plant, "controller": controller, "period_s": kw.pop("period_s", 0.01),
           "scenario": kw.pop("scenario", {"duration_s": 3.0, "reference": [{"t": 0.0, "value": 1.0}]})}
    sec.update(kw)
    return ClosedLoopObjective.from_config(sec)


def test_first_order_step_is_the_closed_form():
    """ZOH is exact for a step: y(kh) = K (1 - exp(-kh / tau)) for K / (tau s + 1)."""
    o = _obj({"tf": {"num": [2.0], "den": [0.5, 1.0]}})
    s = o.simulate({})
    t = s["t"]
    assert np.allclose(s["y"][:, 0], 2.0 * (1.0 - np.exp(-t / 0.5)), atol=1e-12)


@pytest.mark.parametrize("model", [
    {"tf": {"num": [1.0, 2.0], "den": [1.0, 3.0, 3.0, 1.0]}, "delay_s": 0.2},
    {"zpk": {"z": [-2.0], "p": [-1.0, -1.0, -1.0], "k": 1.0}, "delay_s": 0.2},
    {"ss": {"A": [[0, 1], [-2, -0.5]], "B": [[0], [1]], "C": [[1, 0]], "D": [[0]]}},
])
def test_step_response_matches_python_control(model):
    """A delayed step through the kernel equals python-control's continuous step response (ZOH exact)."""
    o = _obj(model)
    s = o.simulate({})
    body = model.get("tf") or model.get("zpk") or model["ss"]
    if "tf" in model:
        sys = control.tf(body["num"], body["den"])
    elif "zpk" in model:
        sys = control.zpk(body["z"], body["p"], body["k"])
    else:
        sys = control.ss(body["A"], body["B"], body["C"], body["D"])
    d = int(round(model.get("delay_s", 0.0) / 0.01))
    t = s["t"]
    ref = np.zeros_like(t)
    ref[d:] = control.step_response(sys, T=t[: t.size - d]).outputs.reshape(-1)
    assert np.allclose(s["y"][:, 0], ref, atol=1e-9)


def test_tustin_matches_python_control_forced_response():
    o = _obj({"tf": {"num": [1.0], "den": [1.0, 0.4, 4.0]}, "method": "tustin"},
             scenario={"duration_s": 4.0, "reference": {"t": [0, 2, 4], "value": [0, 1, -1]}})
    s = o.simulate({})
    dsys = control.sample_system(control.tf([1.0], [1.0, 0.4, 4.0]), 0.01, method="tustin")
    r = np.interp(s["t"], [0, 2, 4], [0, 1, -1])
    # python-control's states; the kernel samples y before the new input acts (feedthrough of u[k-1])
    dss = control.ss(dsys)
    x = control.forced_response(dss, T=s["t"], U=r, return_x=True).states
    ref = (np.asarray(dss.C) @ x).reshape(-1) + float(dss.D[0, 0]) * np.r_[0.0, r[:-1]]
    assert np.allclose(s["y"][:, 0], ref, atol=1e-9)


def test_pid_loop_matches_python_control_feedback():
    """With b = c = 1 and no limits the 2-DOF PID is C(z) = K + ki/(z-1) + bd (z-1)/(z-ad) on the error:
    the kernel's closed-loop step equals python-control's feedback(C P, 1) step."""
    h, K, Ti, Td, N = 0.01, 2.0, 1.5, 0.2, 8.0
    o = _obj({"tf": {"num": [1.0], "den": [1.0, 3.0, 3.0, 1.0]}}, "pid2dof", period_s=h,
             fixed={"K": K, "Ti_s": Ti, "Td_s": Td, "N": N, "b": 1.0, "c": 1.0, "antiwindup": "none"},
             scenario={"duration_s": 10.0, "reference": [{"t": 0.5, "value": 1.0}]})
    s = o.simulate({})
    ad, bd, ki = Td / (Td + N * h), K * Td * N / (Td + N * h), K * h / Ti
    z = control.tf([1, 0], [1], h)
    C = K + ki / (z - 1) + bd * (z - 1) / (z - ad)
    P = control.sample_system(control.tf([1.0], [1.0, 3.0, 3.0, 1.0]), h)
    ref = control.forced_response(control.feedback(C * P, 1), T=s["t"], U=o.loop._sc.r).outputs.reshape(-1)
    assert np.allclose(s["y"][:, 0], ref, atol=1e-8)


@pytest.mark.parametrize("aw", ["backcalc", "clamp", "none"])
def test_kernel_equals_slow_reference_with_realism(aw):
    """Delay, saturation, rate limit, quanta, seeded noise and a load step: kernel == tests/reference."""
    h = 0.01
    fixed = {"K": 3.0, "Ti_s": 0.8, "Td_s": 0.1, "N": 10.0, "b": 0.7, "c": 0.2, "antiwindup": aw,
             "u_min": -1.5, "u_max": 1.5}
    o = _obj({"tf": {"num": [1.0], "den": [0.5, 1.5, 1.0]}, "delay_s": 0.05}, "pid2dof", period_s=h, fixed=fixed,
             scenario={"duration_s": 6.0, "reference": [{"t": 0.1, "value": 1.0}, {"t": 3.0, "value": -0.5,
                                                                                       "ramp_s": 0.5}],
                       "load": [{"t": 2.0, "value": 0.3}]},
             actuator={"u_min": -1.2, "u_max": 1.3, "rate_limit": 20.0, "quantum": 0.01},
             sensor={"noise_std": 0.01, "quantum": 0.002, "seed": 5})
    s = o.simulate({})
    p = o.loop.plant
    noise = o.loop._sig[:, 2:]
    ctrl = pid_reference(3.0, 0.8, 0.1, 10.0, 0.7, 0.2, h, aw, umin=-1.5, umax=1.5)
    y, u = loop_reference(p.Ad, p.Bd, p.Cd, p.Dd, p.delay_n, p.x0, o.loop._sc.r, o.loop._sc.load, noise, ctrl,
                          -1.2, 1.3, 20.0 * h, 0.01, 0.002)
    assert np.allclose(s["y"], y, atol=1e-10) and np.allclose(s["u"][:, 0], u, atol=1e-10)
    assert np.all(np.abs(np.diff(s["u"][:, 0])) <= 20.0 * h + 1e-9)        # rate limit
    assert np.all((s["u"] >= -1.2 - 1e-12) & (s["u"] <= 1.3 + 1e-12))      # saturation
    assert np.allclose(s["u"] / 0.01, np.round(s["u"] / 0.01), atol=1e-6)  # quantum


def test_noise_is_seeded_and_the_same_for_every_evaluation():
    kw = dict(fixed={"K": 1.0, "Ti_s": 1.0}, sensor={"noise_std": 0.05, "seed": 3})
    a = _obj({"tf": {"num": [1.0], "den": [1.0, 1.0]}}, "pid2dof", **kw)
    b = pickle.loads(pickle.dumps(a))
    assert a({}).fitness == b({}).fitness == a({}).fitness
    c = _obj({"tf": {"num": [1.0], "den": [1.0, 1.0]}}, "pid2dof", fixed={"K": 1.0, "Ti_s": 1.0},
             sensor={"noise_std": 0.05, "seed": 4})
    assert c({}).fitness != a({}).fitness


def test_pi_rejects_a_load_step():
    o = _obj({"tf": {"num": [1.0], "den": [1.0, 1.0]}}, "pid2dof", fixed={"K": 2.0, "Ti_s": 0.5},
             scenario={"duration_s": 20.0, "reference": [], "load": [{"t": 1.0, "value": 1.0}]})
    s = o.simulate({})
    assert abs(s["y"][-1, 0]) < 1e-6 and np.max(s["y"][:, 0]) > 0.1  # moved, then back to 0 (integral action)
    assert s["u"][-1, 0] == pytest.approx(-1.0, abs=1e-6)             # u cancels the load


def test_margins_and_ms_match_python_control():
    h, K, Ti, Td, N = 0.01, 1.2, 2.0, 0.4, 10.0
    o = _obj({"tf": {"num": [1.0], "den": [1.0, 3.0, 3.0, 1.0]}, "delay_s": 0.3}, "pid2dof", period_s=h,
             fixed={"K": K, "Ti_s": Ti, "Td_s": Td, "N": N})
    m = o.loop.loop_margins({})
    ad, bd, ki = Td / (Td + N * h), K * Td * N / (Td + N * h), K * h / Ti
    z = control.tf([1, 0], [1], h)
    C = K + ki / (z - 1) + bd * (z - 1) / (z - ad)
    P = control.sample_system(control.tf([1.0], [1.0, 3.0, 3.0, 1.0]), h) * control.tf([1], [1, 0], h) ** 30
    L = C * P
    with pytest.warns(UserWarning, match="frd"):  # python-control's own frequency-grid method on a delay
        gm, pm, *_ = control.stability_margins(L)
    assert 20 * math.log10(gm) == pytest.approx(m["gm_db"], abs=0.05)
    assert pm == pytest.approx(m["pm_deg"], abs=0.1)
    w = np.logspace(-3, math.log10(math.pi / h * 0.999), 20000)
    ms = np.max(np.abs(1 / (1 + L(np.exp(1j * w * h)))))
    assert ms == pytest.approx(m["ms"], rel=2e-3)


def test_lqr_gain_is_dlqr_and_prefilter_tracks():
    A, B = [[0.0, 1.0], [-2.0, -0.5]], [[0.0], [1.0]]
    o = _obj({"ss": {"A": A, "B": B, "C": [[1.0, 0.0]]}}, "lqr_sf", fixed={"q1": 10.0, "q2": 0.5, "r1": 0.1},
             scenario={"duration_s": 15.0, "reference": [{"t": 0.0, "value": 0.7}]})
    d = control.sample_system(control.ss(A, B, [[1, 0]], [[0]]), 0.01)
    k_ref, _, _ = control.dlqr(d.A, d.B, np.diag([10.0, 0.5]), np.diag([0.1]))
    from objectives.control.plants.controllers import LQRStateFeedback

    k, nbar = LQRStateFeedback.gains(o.coeffs({}))
    assert np.allclose(k, k_ref, rtol=1e-9)
    s = o.simulate({})
    assert s["y"][-1, 0] == pytest.approx(0.7, abs=1e-6)
    # the closed loop's poles are those of python-control's design (the response decays at their rate)
    assert np.max(np.abs(np.linalg.eigvals(d.A - d.B @ k_ref))) < 1.0


@pytest.mark.slow
def test_nonlinear_linear_dynamics_equal_the_lti_plant():
    """dx = A x + B u through RK4 (50 sub-steps) matches the exact ZOH discretisation."""
    o_nl = _obj({"python": "tests.control.loop_dynamics:linear", "x0": [0.0, 0.0], "outputs": [0], "n_sub": 50},
                "pid2dof", fixed={"K": 2.0, "Ti_s": 1.0, "Td_s": 0.1})
    o_lti = _obj({"ss": {"A": [[0, 1], [-2, -0.5]], "B": [[0], [1]], "C": [[1, 0]]}}, "pid2dof",
                 fixed={"K": 2.0, "Ti_s": 1.0, "Td_s": 0.1})
    assert o_nl.loop.plant.compiled
    a, b = o_nl.simulate({}), o_lti.simulate({})
    assert np.allclose(a["y"], b["y"], atol=1e-9)


def test_python_fallback_equals_the_compiled_loop():
    """A dynamics function numba cannot compile runs in Python with the same result."""
    kw = dict(fixed={"K": 2.0, "Ti_s": 1.0}, scenario={"duration_s": 1.0, "reference": [{"t": 0.0, "value": 1.0}]})
    o_py = _obj({"python": "tests.control.loop_dynamics:linear_py", "x0": [0.0, 0.0], "outputs": [0]}, "pid2dof", **kw)
    o_nb = _obj({"python": "tests.control.loop_dynamics:linear", "x0": [0.0, 0.0], "outputs": [0]}, "pid2dof", **kw)
    assert not o_py.loop.plant.compiled and o_nb.loop.plant.compiled
    assert np.array_equal(o_py.simulate({})["y"], o_nb.simulate({})["y"])


def test_cascade_inner_loop_and_margins():
    """Position (outer) over speed (inner) of a motor: the cascade tracks, and its loop response is
    Ci (Co P_pos + P_speed) (checked against python-control)."""
    h = 0.005
    ss = {"A": [[0, 1], [0, -5.0]], "B": [[0], [5.0]], "C": [[1, 0], [0, 1]], "D": [[0], [0]]}
    fx = {"K_o": 4.0, "Ti_o_s": math.inf, "K_i": 0.5, "Ti_i_s": 0.2, "N": 10.0}
    o = _obj({"ss": ss, "output": 0, "inner_output": 1}, "pid_cascade", period_s=h, fixed=fx,
             scenario={"duration_s": 10.0, "reference": [{"t": 0.0, "value": 1.0}]})
    s = o.simulate({})
    assert s["y"][-1, 0] == pytest.approx(1.0, abs=1e-3)
    P = control.sample_system(control.ss(ss["A"], ss["B"], ss["C"], ss["D"]), h)
    z = control.tf([1, 0], [1], h)
    Ci, Co = 0.5 + 0.5 * h / 0.2 / (z - 1), 4.0 + 0 * z
    from objectives.control.plants.analysis import loop_response

    w = o.loop._omega[::50]
    zs = np.exp(1j * w * h)
    pz = P(zs)  # (outputs, inputs, len(w)), python-control's own evaluation of the state space
    ref = Ci(zs) * (Co(zs) * pz[0, 0] + pz[1, 0])
    mine = loop_response(o.loop.ctrl, o.coeffs({}), o.loop.plant, w, {"outputs": o.loop.plant.frequency_response(w)})
    assert np.allclose(mine, ref, rtol=1e-6)


def test_step_metrics_on_a_known_second_order_response():
    """Overshoot of wn^2/(s^2 + 2 zeta wn s + wn^2): exp(-pi zeta / sqrt(1 - zeta^2))."""
    zeta, wn = 0.3, 4.0
    o = _obj({"tf": {"num": [wn**2], "den": [1.0, 2 * zeta * wn, wn**2]}}, period_s=0.001,
             scenario={"duration_s": 6.0, "reference": [{"t": 0.5, "value": 2.0}]},
             requirements={"max_overshoot_pct": 50.0})
    ev = o({})
    assert ev.metrics["overshoot_pct"] == pytest.approx(100 * math.exp(-math.pi * zeta / math.sqrt(1 - zeta**2)),
                                                        abs=0.05)
    settle = 4.0 / (zeta * wn)  # the 2 % envelope exp(-zeta wn t) <= 0.02 sqrt(1 - zeta^2) bounds it
    assert 0.5 * settle < ev.metrics["settling_time_s"] < 1.2 * settle
    assert ev.metrics["ss_error"] < 1e-3
    fail = _obj({"tf": {"num": [wn**2], "den": [1.0, 2 * zeta * wn, wn**2]}}, period_s=0.001,
                scenario={"duration_s": 6.0, "reference": [{"t": 0.5, "value": 2.0}]},
                requirements={"max_overshoot_pct": 20.0})({})
    assert fail.status == "failed" and "overshoot" in fail.error and "37.2" in fail.error


def test_closed_loop_poles_match_python_control():
    """PID with delay and feedthrough-free plant: poles of feedback(C P z^-d) from python-control; an
    unstable gain gives Ms = inf."""
    from objectives.control.plants.analysis import closed_loop_poles

    h, K, Ti, Td, N = 0.05, 1.5, 2.0, 0.3, 10.0
    o = _obj({"tf": {"num": [1.0], "den": [1.0, 3.0, 3.0, 1.0]}, "delay_s": 0.2}, "pid2dof", period_s=h,
             fixed={"K": K, "Ti_s": Ti, "Td_s": Td, "N": N})
    mine = closed_loop_poles(o.loop.ctrl.kind, o.coeffs({}), o.loop.plant)
    ad, bd, ki = Td / (Td + N * h), K * Td * N / (Td + N * h), K * h / Ti
    z = control.tf([1, 0], [1], h)
    C = K + ki / (z - 1) + bd * (z - 1) / (z - ad)
    P = control.sample_system(control.tf([1.0], [1.0, 3.0, 3.0, 1.0]), h) * control.tf([1], [1, 0], h) ** 4
    ref = control.poles(control.feedback(C * P, 1))
    big = lambda p: np.sort(np.abs(p))[::-1][:6]  # noqa: E731 - the dominant ones (the rest sit at 0)
    assert np.allclose(big(mine), big(ref), atol=1e-6)
    assert o({}).metrics["cl_pole_max"] < 1
    bad = _obj({"tf": {"num": [1.0], "den": [1.0, 3.0, 3.0, 1.0]}, "delay_s": 0.2}, "pid2dof", period_s=h,
               fixed={"K": 20.0, "Ti_s": Ti}, requirements={"max_ms": 1.4})({})
    assert bad.status == "failed" and "Ms inf" in bad.error and bad.metrics["cl_pole_max"] > 1


def test_closed_loop_poles_of_state_feedback_and_cascade():
    from objectives.control.plants.analysis import closed_loop_poles
    from objectives.control.plants.controllers import LQRStateFeedback

    A, B = [[0.0, 1.0], [-2.0, -0.5]], [[0.0], [1.0]]
    o = _obj({"ss": {"A": A, "B": B, "C": [[1.0, 0.0]]}}, "lqr_sf", fixed={"q1": 10.0, "q2": 0.5, "r1": 0.1})
    k, _ = LQRStateFeedback.gains(o.coeffs({}))
    p = o.loop.plant
    cl = closed_loop_poles(3, o.coeffs({}), p)
    assert np.allclose(np.sort_complex(cl[np.abs(cl) > 1e-12]),  # the feedthrough's state adds a pole at 0
                       np.sort_complex(np.linalg.eigvals(p.Ad - p.Bd @ k)), atol=1e-9)
    # cascade: the linear closed loop's decay rate equals the simulated one
    ss = {"A": [[0, 1], [0, -5.0]], "B": [[0], [5.0]], "C": [[1, 0], [0, 1]], "D": [[0], [0]]}
    oc = _obj({"ss": ss, "output": 0, "inner_output": 1}, "pid_cascade", period_s=0.005,
              fixed={"K_o": 4.0, "Ti_o_s": math.inf, "K_i": 0.5, "Ti_i_s": 0.2, "N": 10.0, "c": 1.0, "b": 0.5},
              scenario={"duration_s": 30.0, "reference": [{"t": 0.0, "value": 1.0}]})
    rho = np.max(np.abs(closed_loop_poles(2, oc.coeffs({}), oc.loop.plant)))
    y = oc.simulate({})["y"][:, 0]
    e = np.abs(y - y[-1])  # b = 0.5 without outer integral action: y settles off the reference
    env = lambda k: np.max(e[k - 150:k + 150])  # noqa: E731 - the envelope of a possibly oscillating decay
    k1, k2 = 1500, 3000
    assert math.log(env(k2) / env(k1)) / (k2 - k1) == pytest.approx(math.log(rho), rel=0.05)


def test_cost_terms_of_a_decaying_error_are_the_integrals():
    """e = exp(-t): IAE = 1, ISE = 1/2, ITAE = 1, ITSE = 1/4; mae_product is prod mean|s|^w (the loop's
    statistics kernel on a response written by hand, its cost from those statistics)."""
    from objectives.control.plants.cost import cost_of_stats
    from objectives.control.plants.metrics import _item_stats, row_metrics, stat_size, windows

    h = 1e-4
    t = np.arange(0, 30, h)
    e = np.exp(-t)
    r = np.ones_like(t)
    y = np.column_stack([r - e, e])
    u = 2.0 * np.ones((t.size, 1))
    row = np.zeros(stat_size(2, 2))
    _item_stats(y, u, y, r, 0, h, windows(r, np.zeros_like(t)), t.size, 0.0, float(t.size), row)
    terms, means, _ = row_metrics(row, 2, 2)
    assert terms["iae"] == pytest.approx(1.0, rel=1e-3) and terms["ise"] == pytest.approx(0.5, rel=1e-3)
    assert terms["itae"] == pytest.approx(1.0, rel=1e-3) and terms["itse"] == pytest.approx(0.25, rel=1e-3)
    assert terms["effort"] == pytest.approx(4.0 * 30, rel=1e-3) and terms["tv"] == 0.0
    assert cost_of_stats({"iae": 2.0, "ise": 1.0}, terms, means) == pytest.approx(2.0 * terms["iae"] + terms["ise"])
    g = cost_of_stats({"mae_product": {"e": 1.4, "u": 0.4, "y1": 1.0}}, terms, means)
    assert g == pytest.approx(np.mean(e) ** 1.4 * 2.0**0.4 * np.mean(e))


def test_antiwindup_sees_the_actuator_limits():
    """Without own output limits the PID takes the actuator's, so back-calculation and clamping act on its
    saturation: a PI on 1/(s+1) saturating at 1.5 overshoots ~30 % with windup, < 1 % with either scheme."""
    over = {}
    for aw in ("backcalc", "clamp", "none"):
        obj = _obj({"tf": {"num": [1.0], "den": [1.0, 1.0]}}, "pid2dof",
                   fixed={"antiwindup": aw, "K": 5.0, "Ti_s": 0.5, "Td_s": 0.0},
                   scenario={"duration_s": 6.0, "reference": [{"t": 0.1, "value": 1.0}]},
                   actuator={"u_min": -1.5, "u_max": 1.5}, cost={"iae": 1.0})
        assert obj.coeffs({})[8:10].tolist() == [-1.5, 1.5]
        over[aw] = obj({}).metrics["overshoot_pct"]
    assert over["none"] > 20.0 and over["backcalc"] < 1.0 and over["clamp"] < 1.0, over
    own = _obj({"tf": {"num": [1.0], "den": [1.0, 1.0]}}, "pid2dof", fixed={"u_max": 1.0},
               actuator={"u_min": -1.5, "u_max": 1.5})
    assert own.coeffs({})[8:10].tolist() == [-1.5, 1.0]  # a limit of its own is kept
