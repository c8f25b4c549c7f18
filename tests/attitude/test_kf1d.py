"""1-D tilt filters (objectives.attitude.filters.kf1d) against slow references and exact data."""

import math

import numpy as np
import pytest

from objectives.attitude.data.recording import Recording
from objectives.attitude.filters import get_filter
from objectives.attitude.filters.kf1d import AKF1D, KF1D, Madgwick1D, Mahony1D, akf1d_fis, tilt_from_quat
from tests.reference.tilt1d_reference import kf1d_ref, madgwick_imu_ref, mahony_imu_ref

G = 9.81


def tilt_recording(n=4000, rate=800.0, frame="NED", seed=0, ext_acc=0.0, gyr_noise=0.0, acc_noise=0.0,
                   bias=0.0):
    """Tilt about the sensor y axis; gyr[k] is the exact constant rate over [t_k, t_k+1]."""
    rng = np.random.default_rng(seed)
    dt = 1.0 / rate
    t = np.arange(n) * dt
    angle = 0.3 * np.sin(2 * np.pi * 0.4 * t) + 0.2 * np.sin(2 * np.pi * 3.0 * t + 1.0) + 0.1
    rate_y = np.empty(n)
    rate_y[:-1] = np.diff(angle) / dt
    rate_y[-1] = rate_y[-2]
    s = -1.0 if frame == "NED" else 1.0           # up = s * z in the earth frame
    up_s = np.stack([-np.sin(angle), np.zeros(n), np.cos(angle)], axis=1) * s  # sensor up (ENU form * s)
    acc = G * up_s
    # external acceleration along the earth x axis: in the sensor frame R^T (a, 0, 0)
    ax_e = ext_acc * np.sin(2 * np.pi * 1.3 * t)
    acc[:, 0] += ax_e * np.cos(angle)
    acc[:, 2] += ax_e * np.sin(angle)
    gyr = np.zeros((n, 3))
    gyr[:, 1] = rate_y + bias + gyr_noise * rng.standard_normal(n)
    acc = acc + acc_noise * rng.standard_normal((n, 3))
    quat = np.zeros((n, 4))
    quat[:, 0] = np.cos(angle / 2)
    quat[:, 2] = np.sin(angle / 2)
    rec = Recording(name="tilt-test", gyr=gyr, acc=acc, mag=None, dt=dt, quat=quat, frame=frame,
                    extra={"angle": angle})
    return rec, angle


def test_recording_helper_is_consistent_with_frames():
    for frame in ("NED", "ENU"):
        rec, angle = tilt_recording(frame=frame, n=10)
        # acc is the specific force (up) of the truth quaternion
        from objectives.attitude.quaternion import qrot, to_frame
        q_enu = to_frame(rec.quat[3], frame, "ENU")
        up = qrot(np.array([q_enu[0], -q_enu[1], -q_enu[2], -q_enu[3]]), np.array([0.0, 0.0, G]))
        np.testing.assert_allclose(up, rec.acc[3], atol=1e-12)
        assert tilt_from_quat(q_enu, frame, "ENU") == pytest.approx(angle[3], abs=1e-14)


@pytest.mark.parametrize("frame", ["NED", "ENU"])
@pytest.mark.parametrize("name", ["kf1d", "akf1d", "mahony1d", "madgwick1d"])
def test_noise_free_tracks_truth(name, frame):
    rec, angle = tilt_recording(frame=frame)
    res = get_filter(name)().run_detailed(rec)
    err = np.abs(res.diagnostics["angle"] - angle)
    if name == "madgwick1d":
        # the normalised gradient step moves by beta*dt whenever the gradient is not exactly 0
        assert err.max() < 3 * 0.1 * rec.dt
    else:
        assert err.max() < 1e-12
    # the quaternion is the rotation about y by the estimate, in the recording's frame
    np.testing.assert_allclose(res.quat, rec.quat, atol=2 * err.max() + 1e-13)
    assert res.frame == frame


def _theta_a(rec):
    s = -1.0 if rec.frame == "NED" else 1.0
    return np.arctan2(-s * rec.acc[:, 0], s * rec.acc[:, 2])


@pytest.mark.parametrize("frame", ["NED", "ENU"])
def test_kf1d_matches_reference(frame):
    rec, angle = tilt_recording(n=1500, frame=frame, ext_acc=4.0, gyr_noise=0.02, acc_noise=0.3, bias=0.02)
    for p0 in (0.0, 1e-3):
        f = KF1D(rho=0.1, q00=2e-6, q11=1e-8, p0_theta=p0, p0_bias=p0)
        got = f.run_detailed(rec, q0="truth").diagnostics["angle"]
        ref = kf1d_ref(rec.gyr[:, 1], _theta_a(rec), rec.dt, 2e-6, 1e-8, 0.1, theta0=angle[0],
                       P0=np.diag([p0, p0]))
        np.testing.assert_allclose(got, ref, rtol=0, atol=1e-12)


def test_kf1d_estimates_bias_and_is_unit_invariant():
    rec, angle = tilt_recording(n=16000, bias=0.05, acc_noise=0.05, seed=3)
    res = KF1D(rho=0.01, q00=1e-6, q11=1e-7).run_detailed(rec, q0="truth")
    assert np.mean(res.diagnostics["gyr_bias"][-2000:]) == pytest.approx(0.05, abs=0.01)
    # with P0 = 0 only the ratios of Q and R matter: degree-valued variances give the same estimate
    c = (180 / math.pi) ** 2
    res_deg = KF1D(rho=0.01 * c, q00=1e-6 * c, q11=1e-7 * c).run_detailed(rec, q0="truth")
    np.testing.assert_allclose(res_deg.diagnostics["angle"], res.diagnostics["angle"], atol=1e-12)


def test_akf1d_matches_reference_and_scales_R():
    rec, angle = tilt_recording(n=2400, ext_acc=4.0, gyr_noise=0.02, acc_noise=0.3, bias=0.02)
    f = AKF1D()
    res = f.run_detailed(rec, q0="truth")
    d = res.diagnostics
    v = f.values
    ref = kf1d_ref(rec.gyr[:, 1], _theta_a(rec), rec.dt, v["q00"], v["q11"], v["rho"], theta0=angle[0],
                   kscale=d["K"])
    np.testing.assert_allclose(d["angle"], ref, atol=1e-12)
    # the first packet has no measure yet: K = K1; afterwards the external acceleration raises K
    assert np.all(d["K"][:400] == v["K1"]) and np.all(d["ext_acc"][:400] == 0.0)
    assert d["K"][400:].min() > v["K1"]
    fis = f.fis()
    np.testing.assert_allclose(d["K"], fis(np.stack([d["vib_freq_hz"], d["ext_acc"]], axis=1)))
    # Table 3.2: (Z, B) -> K3 and (B, B) -> K5 at the set cores; (S, S) -> K3
    assert fis([0.0, 1.0]) == v["K3"] and fis([10.0, 1.0]) == v["K5"] and fis([3.25, 0.175]) == v["K3"]


def test_adaptive_beats_constant_gain_under_external_acceleration():
    rec, angle = tilt_recording(n=8000, ext_acc=6.0, gyr_noise=0.01, acc_noise=0.1, seed=5)
    mse = {}
    for f in (KF1D(rho=0.05, q00=5e-7, q11=5e-12), AKF1D(rho=0.05, q00=5e-7, q11=5e-12)):
        mse[f.name] = np.mean((f.run_detailed(rec, q0="truth").diagnostics["angle"] - angle)[800:] ** 2)
    assert mse["akf1d"] < 0.5 * mse["kf1d"]


@pytest.mark.parametrize("frame", ["ENU", "NED"])
def test_mahony_madgwick_equal_3d_sample_code(frame):
    """With exact_step=False the 1-D kernels are the 3-D sample code restricted to y rotations."""
    rec, angle = tilt_recording(n=1500, frame=frame, ext_acc=3.0, gyr_noise=0.02, acc_noise=0.2, bias=0.01)
    s = -1.0 if frame == "NED" else 1.0
    acc3 = s * rec.acc  # the sample code's z-up convention
    acc3[:, 1] = 0.0
    gyr3 = rec.gyr.copy()
    q_init = np.array([math.cos(angle[0] / 2), 0.0, math.sin(angle[0] / 2), 0.0])
    ref = madgwick_imu_ref(gyr3, acc3, 0.05, rec.dt, q_init)
    got = Madgwick1D(beta=0.05, exact_step=False).run_detailed(rec, q0="truth").diagnostics["angle"]
    np.testing.assert_allclose(got, 2 * np.arctan2(ref[:, 2], ref[:, 0]), atol=1e-12)
    assert np.abs(ref[:, [1, 3]]).max() < 1e-15  # the 3-D code stays on y rotations
    for kp, ki in ((0.4, 0.0), (0.3, 0.01)):
        ref = mahony_imu_ref(gyr3, acc3, kp, ki, rec.dt, q_init)
        got = Mahony1D(Kp=kp, Ki=ki, exact_step=False).run_detailed(rec, q0="truth").diagnostics["angle"]
        np.testing.assert_allclose(got, 2 * np.arctan2(ref[:, 2], ref[:, 0]), atol=1e-12)


def test_mahony_integral_removes_bias():
    rec, angle = tilt_recording(n=16000, bias=0.05, seed=2)
    res = Mahony1D(Kp=2.0, Ki=1.0).run_detailed(rec, q0="truth")
    assert np.mean(res.diagnostics["gyr_bias"][-1000:]) == pytest.approx(0.05, abs=2e-3)
    assert np.abs(res.diagnostics["angle"] - angle)[-1000:].max() < 2e-3
    res0 = Mahony1D(Kp=0.5, Ki=0.0).run_detailed(rec, q0="truth")  # P only: steady error bias / Kp
    assert np.mean((res0.diagnostics["angle"] - angle)[-4000:]) == pytest.approx(0.05 / 0.5, rel=0.05)


def test_initial_angle_from_accelerometer_and_defaults():
    rec, angle = tilt_recording(n=50)
    for cls in (KF1D, AKF1D, Mahony1D, Madgwick1D):
        assert cls().run_detailed(rec).diagnostics["angle"][0] == pytest.approx(angle[0], abs=1e-14)
        assert set(cls.defaults) == {p.name for p in cls.params}
        sp = cls.space()
        assert sp.dim >= 1
    assert KF1D.defaults["q00"] == 5e-7 and KF1D.defaults["q11"] == 5e-9 and KF1D.defaults["rho"] == 0.05
    assert Mahony1D.defaults == {"Kp": 0.5, "Ki": 0.0, "exact_step": True, "init": "auto"}
    assert Madgwick1D.defaults["beta"] == 0.1


@pytest.mark.parametrize("cls, values, key", [(KF1D, {"rho": 0.0}, "rho"), (AKF1D, {"window": 600}, "fft_length"),
                                              (Mahony1D, {"Ki": -1.0}, "Ki")])
def test_validation(cls, values, key):
    with pytest.raises(ValueError, match=key):
        cls(**values)
    with pytest.raises(ValueError, match="unknown"):
        Madgwick1D(gain=0.1)
    with pytest.raises(ValueError):
        akf1d_fis(6.5, 0.35, [1, 2, 3])
