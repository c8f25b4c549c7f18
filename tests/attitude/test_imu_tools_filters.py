"""The two imu_tools filters (``imu_tools_madgwick``, ``valenti``): the numba kernels against slow per-sample
references written from the papers (tests/reference/imu_tools_reference.py) to 1e-9 rad, and the published
properties: the static case, the convergence rate of the gradient step, drift and bias convergence, the adaptive
gain curve of Valenti's eq. 61."""

from __future__ import annotations

import math

import numpy as np
import pytest

from objectives.attitude.data.bench6dof import bench6dof
from objectives.attitude.data.recording import Recording
from objectives.attitude.filters.imu_tools_madgwick import ImuToolsMadgwick
from objectives.attitude.filters.imu_tools_madgwick.kernel import S as MS
from objectives.attitude.filters.imu_tools_madgwick.kernel import imu_tools_madgwick_kernel
from objectives.attitude.filters.valenti import Valenti
from objectives.attitude.filters.valenti.kernel import coefficients as v_coefficients
from objectives.attitude.filters.valenti.kernel import initial_state as v_initial_state
from objectives.attitude.filters.valenti.kernel import valenti_kernel
from objectives.attitude.quaternion import to_frame
from tests.reference.imu_tools_reference import adaptive_factor, madgwick_node, rot, valenti_node


def angle(q1: np.ndarray, q2: np.ndarray) -> np.ndarray:
    """Rotation angle between rows of q1 and q2, rad, accurate near 0: 2 asin |vec(q1* q2)|."""
    c = q1 * np.array([1.0, -1.0, -1.0, -1.0])
    w1, v1, w2, v2 = c[:, :1], c[:, 1:], q2[:, :1], q2[:, 1:]
    v = w1 * v2 + w2 * v1 + np.cross(v1, v2)
    return 2.0 * np.arcsin(np.clip(np.linalg.norm(v, axis=1), 0.0, 1.0))


@pytest.fixture(scope="module", params=["ENU", "NED"])
def rec(request):
    return bench6dof(duration_s=10.0, rate_hz=100.0, seed=5, frame=request.param)


MADGWICK_CASES = [
    {"world_frame": "enu"}, {"world_frame": "ned"}, {"world_frame": "nwu"},
    {"world_frame": "enu", "use_mag": False}, {"world_frame": "ned", "use_mag": False, "gain": 0.3},
    {"world_frame": "enu", "zeta": 0.05, "gain": 0.05}, {"world_frame": "nwu", "zeta": 0.2},
    {"world_frame": "enu", "mag_bias_x": 3.0, "mag_bias_y": -2.0, "mag_bias_z": 1.0},
]


@pytest.mark.parametrize("case", MADGWICK_CASES, ids=lambda c: "-".join(f"{k}={v}" for k, v in c.items()))
def test_madgwick_kernel_equals_reference(rec, case):
    flt = ImuToolsMadgwick(**case)
    res = flt.run_detailed(rec)
    wf = case["world_frame"]
    ref, wb = madgwick_node(flt.values, rec.gyr, rec.acc, rec.mag, rec.dt)
    ref = to_frame(ref, wf.upper(), rec.frame)
    err = angle(res.quat, ref)
    assert np.isfinite(err).all() and err.max() < 1e-9, err.max()
    np.testing.assert_allclose(res.diagnostics["gyr_bias"], wb, atol=1e-9)
    if case.get("zeta"):
        assert np.abs(wb).max() > 1e-4  # the drift term acted


VALENTI_CASES = [
    {}, {"use_mag": True}, {"use_mag": True, "gain_acc": 0.1, "gain_mag": 0.05},
    {"do_bias_estimation": False}, {"do_adaptive_gain": False, "gain_acc": 0.3},
    {"use_mag": True, "bias_alpha": 0.2, "do_adaptive_gain": False},
]


@pytest.mark.parametrize("case", VALENTI_CASES, ids=lambda c: "-".join(f"{k}={v}" for k, v in c.items()) or "node")
def test_valenti_kernel_equals_reference(rec, case):
    flt = Valenti(**case)
    res = flt.run_detailed(rec)
    ref, b = valenti_node(flt.values, rec.gyr, rec.acc, rec.mag, rec.dt)
    err = angle(res.quat, to_frame(ref, "NWU", rec.frame))
    assert np.isfinite(err).all() and err.max() < 1e-9, err.max()
    np.testing.assert_allclose(res.diagnostics["gyr_bias"], b, atol=1e-12)


def test_given_start_orientation_equals_reference(rec):
    q0 = rec.quat[0]
    m = ImuToolsMadgwick(init="truth").run_detailed(rec)
    ref, _ = madgwick_node(ImuToolsMadgwick().values, rec.gyr, rec.acc, rec.mag, rec.dt,
                           q_start=to_frame(q0, rec.frame, "ENU"))
    assert angle(m.quat, to_frame(ref, "ENU", rec.frame)).max() < 1e-9
    assert angle(m.quat[:1], q0[None]).max() < 1e-12  # the start sample is updated with dt = 0
    v = Valenti(init="truth", use_mag=True).run_detailed(rec)
    ref, _ = valenti_node(Valenti(use_mag=True).values, rec.gyr, rec.acc, rec.mag, rec.dt,
                          q_start=to_frame(q0, rec.frame, "NWU"))
    assert angle(v.quat, to_frame(ref, "NWU", rec.frame)).max() < 1e-9


# --- published properties -------------------------------------------------------------------------------------
def _static(n: int, q_true: np.ndarray, frame: str = "ENU", bias=(0.0, 0.0, 0.0), g: float = 9.81) -> Recording:
    """A sensor at rest with orientation ``q_true`` (sensor-to-earth in ``frame``): exact gravity and field."""
    up = np.array([0.0, 0.0, -1.0 if frame == "NED" else 1.0])
    dip = math.radians(60.0)
    north = {"ENU": [0.0, 1.0, 0.0], "NED": [1.0, 0.0, 0.0], "NWU": [1.0, 0.0, 0.0]}[frame]
    field = 50.0 * (math.cos(dip) * np.array(north) - math.sin(dip) * up)
    qc = q_true * np.array([1.0, -1.0, -1.0, -1.0])
    acc = np.tile(rot(qc, g * up), (n, 1))
    mag = np.tile(rot(qc, field), (n, 1))
    gyr = np.tile(np.asarray(bias, float), (n, 1))
    quat = np.tile(q_true, (n, 1))
    return Recording(name="static", gyr=gyr, acc=acc, mag=mag, quat=quat, dt=0.01,
                     frame="ENU" if frame == "NWU" else frame)


Q_TRUE = np.array([math.cos(0.4), math.sin(0.4) * 0.6, math.sin(0.4) * -0.48, math.sin(0.4) * 0.64])


@pytest.mark.parametrize("frame", ["ENU", "NED"])
def test_madgwick_static_case_starts_exactly_and_stays_within_one_step(frame):
    # the stateless start is the true orientation; the normalised gradient step (report eq. 33) then moves by
    # beta dt each sample even where the gradient all but vanishes, so the estimate stays within 2 beta dt rad
    rec = _static(500, Q_TRUE, frame)
    for wf in ("enu", "ned", "nwu"):
        q = ImuToolsMadgwick(world_frame=wf, gain=0.5).run(rec)
        err = angle(q, rec.quat)
        assert err[0] < 1e-12 and err.max() <= 2 * 0.5 * rec.dt * (1 + 1e-6), wf


def test_madgwick_gradient_step_turns_at_most_at_twice_the_gain():
    # report section 3.2: |q_dot_eps| = beta (eq. 33), so a tilt error shrinks steadily, at most at 2 beta rad/s
    # (the part of the normalised step along the sphere), here above beta
    tilt = np.array([math.cos(math.radians(20)), math.sin(math.radians(20)), 0.0, 0.0])  # 40 deg about x
    rec = _static(101, np.array([1.0, 0.0, 0.0, 0.0]))
    flt = ImuToolsMadgwick(gain=0.1, use_mag=False)
    q = flt.run_detailed(rec, q0=tilt).quat
    err = np.degrees(angle(q, rec.quat))
    assert err[0] == pytest.approx(40.0, abs=1e-9)
    assert np.all(np.diff(err) < 0)
    rate = math.radians(err[0] - err[100]) / 1.0
    assert 0.1 < rate <= 2 * 0.1


def test_madgwick_drift_gain_converges_to_the_gyro_bias():
    bias = np.array([0.01, -0.02, 0.015])
    rec = _static(6000, Q_TRUE, bias=bias)
    # report eqs. 47-48: omega_b integrates the error rate until the compensated rate is zero; with the normalised
    # gradient it keeps a limit cycle of about 2 zeta dt around the bias, whose mean is the bias
    res = ImuToolsMadgwick(gain=0.1, zeta=0.05).run_detailed(rec)
    wb = res.diagnostics["gyr_bias"]
    assert np.abs(wb[:10]).max() < 0.01  # it starts at zero
    np.testing.assert_allclose(wb[-1000:].mean(axis=0), bias, atol=5e-5)
    assert np.abs(wb[-1000:] - bias).max() < 0.1 * np.abs(bias).max()
    assert np.degrees(angle(res.quat[-1000:], rec.quat[-1000:])).max() < 0.2


@pytest.mark.parametrize("use_mag", [False, True])
def test_valenti_static_case_holds_the_start(use_mag):
    # NWU truth: with a magnetometer the start is exact in NWU; without, q_acc has zero heading
    yaw0 = Q_TRUE if use_mag else np.array([math.cos(0.2), math.sin(0.2), 0.0, 0.0])
    rec = _static(500, yaw0, "NWU")
    q = Valenti(use_mag=use_mag, gain_acc=0.3, gain_mag=0.3).run(rec)
    assert angle(q, to_frame(rec.quat, "NWU", "ENU")).max() < 1e-12


def test_valenti_bias_estimate_is_the_low_pass_of_the_rate_at_rest():
    # at rest with a constant rate within the thresholds every sample after the second is steady: the estimate
    # is the first-order low-pass b_k = b (1 - (1 - alpha)^(k-1)) (k = samples after the start sample)
    bias = np.array([0.05, -0.03, 0.1])
    alpha = 0.02
    rec = _static(400, Q_TRUE, "NWU", bias=bias)
    res = Valenti(bias_alpha=alpha).run_detailed(rec)
    k = np.arange(rec.n)
    expected = bias * (1.0 - (1.0 - alpha) ** np.maximum(k - 1, 0))[:, None]
    np.testing.assert_allclose(res.diagnostics["gyr_bias"], expected, rtol=0, atol=1e-14)
    moving = _static(400, Q_TRUE, "NWU", bias=bias * 3)  # 0.3 rad/s about z: above 0.2, never steady
    assert np.abs(Valenti().run_detailed(moving).diagnostics["gyr_bias"]).max() == 0.0


@pytest.mark.parametrize("e, factor", [(0.0, 1.0), (0.05, 1.0), (0.1, 1.0), (0.12, 0.8), (0.15, 0.5),
                                       (0.19, 0.1), (0.2, 0.0), (0.3, 0.0), (-0.15, 0.5)])
def test_valenti_adaptive_gain_curve(e, factor):
    # one correction from a 60 deg tilt error (SLERP regime): the tilt shrinks by exactly alpha f(e) of itself
    assert adaptive_factor(abs(e)) == pytest.approx(factor)
    theta, gain = math.radians(60.0), 0.2
    q_err = np.array([math.cos(theta / 2), math.sin(theta / 2), 0.0, 0.0])  # sensor-to-earth (NWU), truth: identity
    acc = np.array([[0.0, 0.0, 9.81 * (1 + e)]] * 2)
    gyr = np.zeros((2, 3))
    coef = v_coefficients({"gain_acc": gain, "gain_mag": 0.01, "bias_alpha": 0.01, "do_bias_estimation": False,
                           "do_adaptive_gain": True, "use_mag": False}, 0.01, False, 9.80665)
    out = np.empty((2, 4))
    valenti_kernel(gyr, acc, np.zeros((0, 3)), coef, v_initial_state(q_err), out, np.empty((0, 3)))
    left = angle(out[1:], np.array([[1.0, 0.0, 0.0, 0.0]]))[0]
    assert left == pytest.approx((1 - gain * factor) * theta, abs=1e-12)


def test_madgwick_stream_state_resumes():
    rec = bench6dof(duration_s=4.0, rate_hz=100.0, seed=2, frame="ENU")
    flt = ImuToolsMadgwick(zeta=0.1)
    whole = flt.run_detailed(rec).quat
    setup = flt.kernel_setup(rec.dt, True, None, "ENU")
    st, out = setup.state.copy(), np.empty((rec.n, 4))
    for i0, i1 in ((0, 1), (1, 150), (150, rec.n)):
        imu_tools_madgwick_kernel(rec.gyr[i0:i1], rec.acc[i0:i1], rec.mag[i0:i1], setup.coef, st, out[i0:i1],
                                  np.empty((0, 3)))
    assert st[MS.PHASE] == 1.0
    np.testing.assert_array_equal(out, whole)


@pytest.mark.parametrize("cls, kw", [(ImuToolsMadgwick, {"zeta": 0.05}), (ImuToolsMadgwick, {"use_mag": False}),
                                     (Valenti, {"use_mag": True}), (Valenti, {})])
def test_stream_equals_run(cls, kw):
    rec = bench6dof(duration_s=3.0, rate_hz=100.0, seed=4, frame="NED")
    flt = cls(**kw)
    whole = flt.run(rec)
    s = flt.stream(rate_hz=100.0, frame="NED")
    got = np.array([s.update(g, a, m if flt.values["use_mag"] else None) for g, a, m in zip(rec.gyr, rec.acc, rec.mag)])
    assert angle(got, whole).max() < 1e-12
