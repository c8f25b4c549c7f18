"""LQR/LQG design and PID discretisation against independent references; closed-loop stability."""


import numpy as np
import pytest
from scipy.signal import lfilter

from objectives.control.controllers import get_controller
from objectives.control.objective import ClosedLoopObjective
from objectives.control.plants.wmp.controllers.kernels import _tustin_pid
from objectives.control.plants.wmp.controllers.lqr import LQR, linearize, lq_design, reduced_model
from objectives.control.plants.wmp.model import WMPParams
from tests.reference import wmp_reference as ref

P = WMPParams()


def test_numerical_jacobian_matches_analytic_linearisation():
    A, B = linearize(P)
    M0 = ref.mass_matrix_ref(0.0, P)
    Mi = np.linalg.inv(M0)
    fm, fw = P.f_m_Nms, P.f_w_Nms
    Ff = np.array([[fm + fw, 0, -fm], [0, fm + fw, -fm], [-fm, -fm, 2 * fm]])
    G = np.diag([0, 0, P.m_b_kg * P.g_ms2 * P.l_m])
    Ka = P.k_M_NmA * P.gear * np.array([[1, 0], [0, 1], [-1, -1]])
    S = np.array([[1, 0, -1], [0, 1, -1]])
    Aa = np.zeros((8, 8))
    Aa[:3, 3:6] = np.eye(3)
    Aa[3:6, :3] = -Mi @ G
    Aa[3:6, 3:6] = -Mi @ Ff
    Aa[3:6, 6:] = Mi @ Ka
    Aa[6:, 3:6] = -P.k_E_Vs * P.gear * S / P.L_H
    Aa[6:, 6:] = -P.R_ohm / P.L_H * np.eye(2)
    Ba = np.zeros((8, 2))
    Ba[6:] = np.eye(2) / P.L_H
    np.testing.assert_allclose(A, Aa, rtol=1e-5, atol=1e-6 * np.abs(Aa).max())
    np.testing.assert_allclose(B, Ba, rtol=1e-6)


def test_controllable_subsystem_and_riccati_gain():
    Ac, Bc, Cc = reduced_model(P)
    ctrb = np.hstack([np.linalg.matrix_power(Ac, i) @ Bc for i in range(4)])
    assert np.linalg.matrix_rank(ctrb) == 4
    q = np.array([14.5, 156.2, 1.3, 1.3])
    rw = np.array([0.1, 0.1])
    des = lq_design(q, rw, 0.01, P)
    Ad, Bd, K = des.Ad, des.Bd, des.K
    # reference: plain Riccati value iteration
    Q, R = np.diag(q), np.diag(rw)
    Pm = Q.copy()
    for _ in range(20000):
        Kr = np.linalg.solve(R + Bd.T @ Pm @ Bd, Bd.T @ Pm @ Ad)
        Pn = Q + Ad.T @ Pm @ (Ad - Bd @ Kr)
        if np.max(np.abs(Pn - Pm)) < 1e-12 * np.max(np.abs(Pn)):
            break
        Pm = Pn
    np.testing.assert_allclose(K, Kr, rtol=1e-6)
    assert np.max(np.abs(np.linalg.eigvals(Ad - Bd @ K))) < 1.0
    # eq. 2.15: the linear closed loop tracks (nu_d, xi_d) without steady-state error
    dc = Cc @ np.linalg.solve(np.eye(4) - (Ad - Bd @ K), Bd @ des.Fr)
    np.testing.assert_allclose(dc, np.eye(2), atol=1e-9)


def test_lq_design_result_carries_riccati_solution_and_closed_loop_poles():
    des = lq_design(np.array([14.5, 156.2, 1.3, 1.3]), np.array([0.1, 0.1]), 0.01, P)
    Q, R = np.diag([14.5, 156.2, 1.3, 1.3]), np.diag([0.1, 0.1])
    # P solves the DARE: P = Q + Ad' P Ad - Ad' P Bd (R + Bd' P Bd)^-1 Bd' P Ad, and K follows from it
    Ad, Bd, Pr = des.Ad, des.Bd, des.P
    dare = Q + Ad.T @ Pr @ Ad - Ad.T @ Pr @ Bd @ np.linalg.solve(R + Bd.T @ Pr @ Bd, Bd.T @ Pr @ Ad)
    np.testing.assert_allclose(dare, Pr, rtol=1e-9, atol=1e-9 * np.abs(Pr).max())
    np.testing.assert_allclose(np.linalg.eigvalsh(0.5 * (Pr + Pr.T)) > 0, True)
    np.testing.assert_allclose(np.sort_complex(des.poles), np.sort_complex(np.linalg.eigvals(Ad - Bd @ des.K)))
    assert np.all(np.abs(des.poles) < 1.0)
    np.testing.assert_allclose(des.Fr, des.Nu + des.K @ des.Nx)
    with pytest.raises(AttributeError):
        des.K = np.zeros((2, 4))


def test_tustin_pid_matches_transfer_function():
    kp, ki, kd, ts = 2.0, 5.0, 0.01, 0.01
    e = np.random.default_rng(0).normal(size=200)
    st = np.zeros(3)
    u = np.array([_tustin_pid(kp, ki, kd, ts, ek, st, 0) for ek in e])
    # eq. 2.38 as one rational function of z^-1
    num_i, den_i = np.array([ki * ts / 2, ki * ts / 2]), np.array([1.0, -1.0])
    num_d, den_d = np.array([2 * kd / ts, -2 * kd / ts]), np.array([1.0, 1.0])
    expected = kp * e + lfilter(num_i, den_i, e) + lfilter(num_d, den_d, e)
    np.testing.assert_allclose(u, expected, rtol=1e-10, atol=1e-12)


@pytest.mark.parametrize("name", ["lqr", "lqg", "pid"])
def test_each_controller_stabilises_the_thesis_profile_with_initial_parameters(name):
    obj = ClosedLoopObjective(controller=name)
    sim = obj.simulate(obj.defaults)
    assert sim["status_name"] == "ok"
    y, r = sim["outputs"], sim["references"]
    # last 0.2 s of each 2.5 s segment: references reached on average (the Tustin derivative of
    # PID2 has a pole at z = -1, so the initial PID's voltages keep alternating at the Nyquist rate)
    for end in (250, 500, 750, 1000):
        seg = slice(end - 20, end)
        assert abs(np.mean(y[seg, 0] - r[seg, 0])) < 0.02
        assert abs(np.mean(y[seg, 3] - r[seg, 1])) < np.radians(3)
    assert np.max(np.abs(np.degrees(y[-100:, 1]))) < 10  # oscillation suppressed at the end
    ev = obj(obj.defaults)
    assert ev.status == "ok" and np.isfinite(ev.fitness) and 0 < ev.fitness < 1
    print(f"F_init({name}) = {ev.fitness:.4f}")


def test_lqr_initial_overshoot_matches_thesis_table_2_4():
    # simulated linear control: max IB angle 29.9 deg (Table 2.4); ours with the same Q, R
    obj = ClosedLoopObjective(controller="lqr")
    ev = obj(obj.defaults)
    assert ev.metrics["peak_theta3_deg"] == pytest.approx(29.9, abs=3.0)


def test_registry_and_parameter_checks():
    assert get_controller("lqg").name == "lqg"
    with pytest.raises(ValueError, match="unknown controller"):
        get_controller("fuzzy_magic")
    with pytest.raises(ValueError, match="unknown parameter"):
        LQR().param_array({"q_theta": 1.0})
    with pytest.raises(ValueError, match=r"need q \(4,\) >= 0 and r \(2,\) > 0, got q=\[1\. 1\. 1\. 1\.\], r=\[0\.1"):
        lq_design(np.ones(4), np.array([0.1, 0.0]), 0.01)
    with pytest.raises(ValueError, match=r"need q \(4,\) >= 0 .* got q=\[ 1\. -1\.  1\.  1\.\]"):
        lq_design(np.array([1.0, -1.0, 1.0, 1.0]), np.array([0.1, 0.1]), 0.01)
