"""The WMP plant kernel against a Lagrangian reference, Radau, closed forms and invariants."""


import numpy as np
import pytest
from scipy.integrate import solve_ivp

from objectives.control.plants.wmp.model import (
    SensorParams,
    WMPParams,
    derivatives,
    mass_matrix,
    simulate_closed_loop,
    simulate_open_loop,
)
from tests.reference import wmp_reference as ref

P = WMPParams()


def test_derivatives_match_lagrangian_reference():
    rng = np.random.default_rng(3)
    for _ in range(20):
        x = rng.normal(size=8) * np.array([1, 1, 1, 10, 10, 5, 0.3, 0.3])
        u = rng.uniform(-3, 3, 2)
        np.testing.assert_allclose(derivatives(x, u, P), ref.derivatives_ref(x, u, P), rtol=1e-6, atol=1e-6)
        np.testing.assert_allclose(mass_matrix(x[2], P), ref.mass_matrix_ref(x[2], P), rtol=1e-10)


def test_rest_is_equilibrium():
    np.testing.assert_array_equal(derivatives(np.zeros(8), np.zeros(2), P), np.zeros(8))
    r = simulate_open_loop((0.0, 0.0), 1.0, P)
    assert r["status_name"] == "ok"
    assert np.max(np.abs(r["x"])) == 0.0


@pytest.mark.slow
def test_kernel_matches_radau_over_one_second():
    x0 = np.array([0, 0, 0.3, 0, 0, 0, 0, 0.0])
    u = (1.0, 1.6)
    sim = simulate_open_loop(u, 1.0, P, x0=x0, n_sub=10)
    sol = solve_ivp(
        lambda t, x: ref.derivatives_ref(x, u, P),
        (0, 0.99),
        x0,
        method="Radau",
        t_eval=sim["t"],
        rtol=1e-9,
        atol=1e-9,
    )
    assert sol.success
    xr = sol.y.T
    scale = np.max(np.abs(xr), axis=0) + 1e-3
    err = np.max(np.abs(sim["x"] - xr), axis=0) / scale
    # the only approximation is the dropped current lag (L/R) dI_ss/dt: ~5e-4 of each range
    assert np.all(err < 2e-3), err


def test_large_steps_stay_stable_and_converge():
    # h = Ts (10 ms, ~900 L/R): an explicit RK4 on eq. 2.12 would explode; ours stays close
    x0 = np.array([0, 0, 0.5, 0, 0, 0, 0, 0.0])
    fine = simulate_open_loop((1.3, 1.3), 2.0, P, x0=x0, n_sub=40)["x"]
    coarse = simulate_open_loop((1.3, 1.3), 2.0, P, x0=x0, n_sub=1)["x"]
    mid = simulate_open_loop((1.3, 1.3), 2.0, P, x0=x0, n_sub=10)["x"]
    assert np.all(np.isfinite(coarse))
    e_coarse = np.max(np.abs(coarse[:, 2] - fine[:, 2]))
    e_mid = np.max(np.abs(mid[:, 2] - fine[:, 2]))
    assert e_coarse < 0.05 and e_mid < e_coarse / 10


def test_energy_conserved_without_friction_and_input():
    p = WMPParams.from_dict({"f_m_Nms": 0.0, "f_w_Nms": 0.0, "k_M_NmA": 0.0, "k_E_Vs": 0.0})
    x0 = np.array([0, 0, 1.0, 3.0, -2.0, 1.0, 0, 0])
    sim = simulate_open_loop((0.0, 0.0), 3.0, p, x0=x0, n_sub=10)
    e = np.array([ref.energy_ref(x, p) for x in sim["x"]])
    assert np.ptp(e) / abs(e[0]) < 1e-7
    assert np.ptp(sim["x"][:, 2]) > 1.0  # it really swung


def test_step_of_1v3_reaches_closed_form_steady_state():
    w, i, th3 = ref.steady_state_ref(1.3, P)
    sim = simulate_open_loop((1.3, 1.3), 40.0, P)
    y = sim["y"][-1]
    assert y[0] == pytest.approx(P.r_m * w, rel=2e-3)  # ~0.304 m/s
    assert y[4] == pytest.approx(i, rel=1e-2)  # ~15 mA
    assert y[1] == pytest.approx(th3, abs=np.radians(0.2))  # ~ -6.8 deg
    assert abs(y[3]) < 1e-9


@pytest.mark.parametrize(
    "bad, word",
    [
        ({"m_b_kg": -0.3}, "m_b_kg"),
        ({"L_H": 0.0}, "L_H"),
        ({"R_ohm": float("nan")}, "R_ohm"),
        ({"mass": 1.0}, "unknown"),
    ],
)
def test_bad_parameters_are_clear_errors(bad, word):
    with pytest.raises(ValueError, match=word):
        WMPParams.from_dict(bad)


def test_bad_inputs_are_errors():
    with pytest.raises(ValueError, match="ref"):
        simulate_closed_loop(0, np.zeros(2), 0, np.zeros((5, 3)))
    with pytest.raises(ValueError, match="noise"):
        simulate_closed_loop(0, np.zeros(2), 0, np.zeros((5, 2)), noise=np.zeros((4, 4)))
    with pytest.raises(ValueError, match="gyro_noise_dps"):
        SensorParams(gyro_noise_dps=-1.0)


def test_fall_and_divergence_end_the_run_with_a_status():
    r = simulate_open_loop((3.3, 3.3), 2.0, P, fall_limit_deg=10.0)
    assert r["status_name"] == "fell" and r["n_done"] < 200
    assert np.all(np.isnan(r["y"][r["n_done"] :]))
    r = simulate_closed_loop(99, np.zeros(1), 0, np.zeros((10, 2)))  # unknown kind -> NaN voltages
    assert r["status_name"] == "diverged"
