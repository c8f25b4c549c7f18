"""LCF, NCF and CCF (Narkhede et al. 2021): slow reference, the Kp/Ki grid of Tables 1-2, angle
wrap, frames, degenerate input."""

from __future__ import annotations

import numpy as np
import pytest

from objectives.attitude.data.synthetic import simulate_imu
from objectives.attitude.filters import get_filter
from objectives.attitude.filters.complementary import (
    CCF,
    LCF,
    NCF,
    complementary_batch,
    euler_zyx_from_quat,
    quat_from_euler_zyx,
)
from objectives.attitude.metrics import broad_errors
from objectives.attitude.quaternion import to_frame
from tests.attitude.robust_cases import degenerate_arrays, digest, digest_recordings
from tests.reference.complementary_reference import complementary_ref, measured_angles, wrap

DT = 0.01


def _euler_traj(n, yaw_amp=1.5):
    t = np.arange(n) * DT
    return np.stack([0.5 * np.sin(0.5 * t), 0.4 * np.sin(0.3 * t + 1), yaw_amp * np.sin(0.1 * t)], 1)


@pytest.fixture(scope="module")
def biased():
    """100 Hz, 30 s, gyro bias 0.1 rad/s per axis, small noise (NED)."""
    return simulate_imu(quat_from_euler_zyx(_euler_traj(3000)), DT, frame="NED", rng=np.random.default_rng(1),
                        gyr_noise=0.001, acc_noise=0.002, mag_noise=0.001, gyr_bias=(0.1, -0.1, 0.1))


def test_euler_helpers_round_trip():
    e = np.array([[0.3, -1.2, 3.0], [-2.9, 0.7, -0.4], [0.0, 0.0, 0.0]])
    assert np.allclose(euler_zyx_from_quat(quat_from_euler_zyx(e)), e, atol=1e-12)


def test_measurement_angles_eqs_4_to_6():
    """The kernel's x_a (LCF with alpha = 0 outputs x_a) equals the rotation-matrix reference and the
    truth on noise-free data, over the full roll and yaw range."""
    e = np.array([[0.3, -1.2, 3.0], [-2.9, 0.7, -3.1], [1.7, 0.2, 0.1], [0.0, 1.3, -1.6]])
    rec = simulate_imu(quat_from_euler_zyx(e), DT, frame="NED")
    out = complementary_batch(rec.gyr, rec.acc, rec.mag, DT, np.zeros(3), alpha=0.0, detailed=True)[1]
    ref = np.array([measured_angles(a, m) for a, m in zip(rec.acc, rec.mag)], float)
    assert np.abs(wrap(out - ref)).max() < 1e-9
    assert np.abs(wrap(out - e)).max() < 1e-9


@pytest.mark.parametrize("alpha,kp,ki", [(0.98, 0.0, 0.0), (1.0, 2.0, 0.5), (0.7, 25.0, 0.1), (0.9, 1.0, 1.0)])
@pytest.mark.parametrize("use_mag", [True, False])
def test_kernel_matches_reference(biased, alpha, kp, ki, use_mag):
    r = biased.slice(0, 800)
    mag = r.mag if use_mag else None
    x0 = np.array([0.1, -0.2, 0.3])
    got = complementary_batch(r.gyr, r.acc, mag, DT, x0, alpha, kp, ki, detailed=True)[1]
    ref = complementary_ref(r.gyr, r.acc, mag, DT, x0, alpha, kp, ki)
    assert np.abs(wrap(got - ref)).max() < 1e-9


def test_ccf_insensitive_to_kp_ki_while_ncf_is_not(biased):
    """Direction of Tables 1-2: over the paper's grid Kp in {75, 25, 1, 0.1}, Ki in {0.01, 0.1, 1}
    (alpha = 0.7 for CCF), the NCF's error changes by an order of magnitude and more while the CCF's
    stays within a factor of two (on a recording with a large gyro bias)."""
    rec = biased
    ncf, ccf = [], []
    for kp in (75.0, 25.0, 1.0, 0.1):
        for ki in (0.01, 0.1, 1.0):
            ncf.append(broad_errors(NCF(Kp=kp, Ki=ki).run(rec), rec.quat).total_rmse_deg)
            ccf.append(broad_errors(CCF(alpha=0.7, Kp=kp, Ki=ki).run(rec), rec.quat).total_rmse_deg)
    ncf, ccf = np.array(ncf), np.array(ccf)
    assert ncf.max() / ncf.min() > 10
    assert ccf.max() / ccf.min() < 2.5
    assert ncf.std() / ncf.mean() > 3 * ccf.std() / ccf.mean()


def test_lcf_has_no_bias_estimate_but_ncf_finds_it(biased):
    rec = biased
    lcf = LCF(alpha=0.98).run_detailed(rec)
    ncf = NCF(Kp=1.0, Ki=0.5).run_detailed(rec)
    assert np.all(lcf.diagnostics["gyr_bias"] == 0)
    # Euler-rate bias: the body bias mapped by the ZYX kinematics; averaged over the last 10 s it
    # has the sign pattern and size of the true (0.1, -0.1, 0.1) rad/s near level attitude
    b = ncf.diagnostics["gyr_bias"][-1000:].mean(axis=0)
    assert np.all(np.abs(b) > 0.05) and b[1] < 0
    assert broad_errors(ncf.quat, rec.quat).total_rmse_deg < broad_errors(lcf.quat, rec.quat).total_rmse_deg


def test_yaw_wraps_without_jumps():
    """A steady yaw rotation through +-180 deg: the estimate follows without a 360 deg excursion."""
    n = 2000
    t = np.arange(n) * DT
    e = np.stack([0.2 * np.ones(n), -0.1 * np.ones(n), wrap(0.8 * t + 2.5)], 1)
    rec = simulate_imu(quat_from_euler_zyx(e), DT, frame="NED")
    for f in (LCF(alpha=0.95), NCF(Kp=2.0, Ki=0.1), CCF()):
        est = f.run_detailed(rec)
        assert np.abs(wrap(est.diagnostics["euler"][:, 2] - e[:, 2])).max() < 0.01
        assert broad_errors(est.quat, rec.quat).total_rmse_deg < 0.5


@pytest.mark.parametrize("cls", [LCF, NCF, CCF])
def test_output_frame_follows_recording(cls):
    e = _euler_traj(600)
    q_ned = quat_from_euler_zyx(e)
    kw = dict(rng=None)
    rec_ned = simulate_imu(q_ned, DT, frame="NED", **kw)
    rec_enu = simulate_imu(to_frame(q_ned, "NED", "ENU"), DT, frame="ENU", **kw)
    a = cls().run(rec_ned)
    b = cls().run(rec_enu)
    d = np.minimum(np.abs(to_frame(b, "ENU", "NED") - a).max(1), np.abs(to_frame(b, "ENU", "NED") + a).max(1))
    assert d.max() < 1e-9
    assert broad_errors(a, rec_ned.quat).total_rmse_deg < 0.5


def test_no_mag_leaves_yaw_to_the_gyroscope():
    e = _euler_traj(1000)
    rec = simulate_imu(quat_from_euler_zyx(e), DT, frame="NED", gyr_bias=(0.0, 0.0, 0.05))
    with_mag = CCF().run_detailed(rec).diagnostics["euler"][:, 2]
    no_mag = CCF(use_mag=False).run_detailed(rec, q0="truth").diagnostics["euler"][:, 2]
    # without the magnetometer the yaw drifts with the z bias (about 0.05 rad/s x 10 s, attitude-mapped)
    assert np.abs(wrap(with_mag - e[:, 2])).max() < 0.05
    assert np.abs(wrap(no_mag[-1] - e[-1, 2])) > 0.2


@pytest.mark.parametrize("alpha,kp,ki", [(0.98, 0.0, 0.0), (1.0, 2.0, 0.5), (0.7, 25.0, 0.1)])
def test_degenerate_samples(biased, alpha, kp, ki):
    r = biased.slice(0, 1000)
    g, a, m = r.gyr.copy(), r.acc.copy(), r.mag.copy()
    x0 = euler_zyx_from_quat(r.quat[0])
    clean = complementary_batch(g, a, m, DT, x0, alpha, kp, ki)
    a[100] = 0.0
    a[200] = np.nan
    m[300] = 0.0
    m[310, 2] = -np.inf
    g[400] = np.nan
    got = complementary_batch(g, a, m, DT, x0, alpha, kp, ki)
    assert np.isfinite(got).all() and np.allclose(np.linalg.norm(got, axis=1), 1.0)
    assert np.array_equal(got[:100], clean[:100])
    assert broad_errors(got[-100:], clean[-100:]).total_rmse_deg < 0.5
    # zero acc: a pure gyro step of all three angles
    one = complementary_batch(g[:1], np.zeros((1, 3)), m[:1], DT, x0, alpha, kp, ki, detailed=True)[1]
    gyro = complementary_batch(g[:1], np.zeros((1, 3)), None, DT, x0, 1.0, 0.0, 0.0, detailed=True)[1]
    assert np.allclose(one, gyro, atol=1e-15)


def test_registry_and_validation():
    assert get_filter("lcf") is LCF and get_filter("ncf") is NCF and get_filter("ccf") is CCF
    assert LCF.space().dim == 1 and NCF.space().dim == 2 and CCF.space().dim == 3
    assert CCF().values["alpha"] == 0.7
    with pytest.raises(ValueError, match="alpha"):
        LCF(alpha=1.5)
    with pytest.raises(ValueError, match=r"ncf: Kp must be in \[0, inf\) 1/s, got -1.0"):
        NCF(Kp=-1.0)
    with pytest.raises(ValueError, match="euler0"):
        complementary_batch(np.zeros((3, 3)), np.ones((3, 3)), None, DT, np.zeros(2))


def test_alpha_rate_keeps_the_lcf_time_constant():
    """alpha defined at f_ref: the step response of the LCF (tau = alpha / (f_ref (1 - alpha))) is the same
    at every rate; alpha_rate_hz = recording rate, or 0, reproduces the per-sample filter exactly."""
    from objectives.attitude.filters.complementary import alpha_at_rate

    assert alpha_at_rate(0.7, 100.0, 0.01) == pytest.approx(0.7, abs=1e-15)
    assert alpha_at_rate(0.7, 0.0, 0.001) == 0.7 and alpha_at_rate(1.0, 50.0, 0.001) == 1.0
    # closed form: tau = 0.7 / (50 * 0.3) = 46.7 ms; at 1 kHz alpha_eff = tau / (tau + 1 ms)
    tau = 0.7 / (50 * 0.3)
    assert alpha_at_rate(0.7, 50.0, 0.001) == pytest.approx(tau / (tau + 0.001), rel=1e-14)
    # the roll response to a step of the accelerometer angle (gyro at rest): x_k = 1 - alpha_eff^k,
    # i.e. 1 - exp(-t / tau') with tau' -> tau as dt -> 0; compare at t = tau at 100 Hz and 1 kHz
    reached = {}
    for rate in (100.0, 1000.0):
        dt = 1.0 / rate
        n = int(round(0.5 * rate))
        q = quat_from_euler_zyx(np.tile([0.2, 0.0, 0.0], (n, 1)))
        rec = simulate_imu(q, dt, frame="NED")
        out = LCF(alpha=0.7, alpha_rate_hz=50.0).run_detailed(rec, q0=[1.0, 0.0, 0.0, 0.0]).diagnostics["euler"]
        k = int(round(tau * rate))
        reached[rate] = out[k - 1, 0] / 0.2
    assert reached[100.0] == pytest.approx(reached[1000.0], abs=0.03)
    assert reached[1000.0] == pytest.approx(1 - np.exp(-1), abs=0.03)
    # per-sample default unchanged
    rec = simulate_imu(quat_from_euler_zyx(np.tile([0.2, 0.0, 0.0], (50, 1))), 0.02, frame="NED")
    a = CCF().run(rec)
    b = CCF(alpha_rate_hz=50.0).run(rec)
    assert np.array_equal(a, b)


# --- alpha_mode: the seed's per-sample blend unchanged, the time-constant and eq. (14) readings ---------------
# Computed with the kernel of commit a77527f (before the kernel's shared blocks became inline helpers and
# alpha_mode was added), on the recordings below, and recomputed once when the kernels dropped fastmath
# (objectives.jit; the paper kernel is now the robust kernel with its blocks off, the same bits); they hold
# for the pinned NumPy/numba on x86-64 (see tests/attitude/test_synthetic_identity.py for what to do after an
# upgrade).
PER_SAMPLE_DIGESTS = {
    "lcf_rate": "ee37f977fd94dc49fb40e85f7ba65833d240cf1719ae2013381aaf73aef7dbe7",
    "ncf": "c144c234f4a38a341fe0e9d47b1057cb19d2bcd5d07a97e6526f6b2171773666",
    "ccf": "8c9558602f7943429e71c89846808b24fde8b65766ed8ad5f17e66ad5191e83f",
    "ccf_gate": "26f14d6c503bdd3413a7fc3477ec1d45556a0e42a02b1d21441f110bfbc290ba",
    "ccf_nomag": "6a913b74a870545d27f6bbacac5b6ccab2e4a00d0555cc91320eff5f432dc8f6",
    "batch_degenerate": "d3d6e2c518d5ffa2d268f8e84ef8c3ffffdc39349ddf3ad11c384833ee8a918f",
    "batch_degenerate_gate": "332abc333ae10c639c4be1f5dc63081e79bec8802a4c602da25a97ca6e78b2d3",
    "stream": "094bc9ff76de68d35bb0e30e6a97f2041cffeb8e43bf10ac5778c21e140197f7",
}


def test_per_sample_mode_is_bit_identical_to_the_seed_kernel():
    rec, rec2 = digest_recordings()
    got = {}
    for key, f, r in (("lcf_rate", LCF(alpha=0.9, alpha_rate_hz=50.0), rec), ("ncf", NCF(Kp=3.0, Ki=0.05), rec),
                      ("ccf", CCF(), rec), ("ccf_gate", CCF(alpha=0.9, Kp=2.0, Ki=0.3, acc_gate=0.2), rec2),
                      ("ccf_nomag", CCF(use_mag=False), rec)):
        res = f.run_detailed(r)
        got[key] = digest(res.quat, res.diagnostics["euler"], res.diagnostics["gyr_bias"])
    g, a, m = degenerate_arrays(rec)
    x0 = [0.1, -0.2, 0.3]
    got["batch_degenerate"] = digest(*complementary_batch(g, a, m, 0.01, x0, 0.7, 25.0, 0.1, detailed=True))
    got["batch_degenerate_gate"] = digest(*complementary_batch(g, a, m, 0.01, x0, 1.0, 1.0, 0.1, detailed=True,
                                                                acc_gate=0.3, g_ref=9.80665))
    s = CCF(alpha=0.9, Kp=2.0, Ki=0.3).stream(rate_hz=100.0, frame=rec.frame)
    got["stream"] = digest(np.array([s.update(rec.gyr[i], rec.acc[i], rec.mag[i]) for i in range(500)]))
    assert got == PER_SAMPLE_DIGESTS
    assert np.array_equal(CCF(alpha_mode="per_sample").run(rec), CCF().run(rec))


@pytest.mark.parametrize("alpha,kp,ki", [(0.7, 25.0, 0.1), (0.9, 1.0, 1.0), (0.5, 0.0, 0.0)])
@pytest.mark.parametrize("use_mag", [True, False])
def test_static_mode_matches_reference(biased, alpha, kp, ki, use_mag):
    """Eq. (14) as written (static output weight), against the slow reference written from the equation."""
    r = biased.slice(0, 800)
    mag = r.mag if use_mag else None
    x0 = np.array([0.1, -0.2, 0.3])
    got = complementary_batch(r.gyr, r.acc, mag, DT, x0, alpha, kp, ki, detailed=True, static=True)[1]
    ref = complementary_ref(r.gyr, r.acc, mag, DT, x0, alpha, kp, ki, static=True)
    assert np.abs(wrap(got - ref)).max() < 1e-9


def test_static_mode_is_eq_15():
    """Step of the accelerometer roll at rest: the output follows eq. (15)'s
    ((1 - a) s^2 + a Kp s + a Ki) / (s^2 + a Kp s + a Ki), a direct feed-through of 1 - alpha at t = 0+,
    at 100 Hz and 1 kHz alike (alpha is rate-independent); at alpha = 1 it is the NCF bit for bit."""
    from scipy import signal

    a, kp, ki, step = 0.7, 4.0, 2.0, 0.2
    t_end = 3.0
    for rate in (100.0, 1000.0):
        dt = 1.0 / rate
        n = int(round(t_end * rate))
        q = quat_from_euler_zyx(np.tile([step, 0.0, 0.0], (n, 1)))
        rec = simulate_imu(q, dt, frame="NED")
        f = CCF(alpha=a, Kp=kp, Ki=ki, alpha_mode="static")
        roll = f.run_detailed(rec, q0=[1.0, 0.0, 0.0, 0.0]).diagnostics["euler"][:, 0]
        t = np.arange(1, n + 1) * dt
        _, y = signal.step(([1 - a, a * kp, a * ki], [1.0, a * kp, a * ki]), T=t)
        assert roll[0] / step == pytest.approx(1 - a, abs=0.05)
        assert np.abs(roll / step - y).max() < (0.03 if rate == 100.0 else 0.004)
    rec = simulate_imu(quat_from_euler_zyx(_euler_traj(500)), DT, frame="NED", rng=np.random.default_rng(2),
                       gyr_noise=0.01, acc_noise=0.05, mag_noise=0.01)
    assert np.array_equal(CCF(alpha=1.0, Kp=kp, Ki=ki, alpha_mode="static").run(rec), NCF(Kp=kp, Ki=ki).run(rec))


def test_tau_mode_is_rate_independent_and_stays_stable():
    """tau_s fixes the LCF time constant of eq. (9) at every rate (x reaches 1 - 1/e of a step at t = tau);
    a proportional gain far above 2 / dt leaves the tau-mode CCF bounded where the per-sample one diverges."""
    from objectives.attitude.filters.complementary import tau_gains

    al, kpe = tau_gains(0.05, 10.0, 0.01)
    assert al == pytest.approx(0.05 / 0.06, rel=1e-15) and kpe == pytest.approx((1 - np.exp(-0.1)) / 0.01, rel=1e-12)
    assert tau_gains(0.05, 1e6, 0.01)[1] * 0.01 <= 1.0
    tau = 0.05
    for rate in (100.0, 1000.0):
        dt = 1.0 / rate
        n = int(round(0.3 * rate))
        q = quat_from_euler_zyx(np.tile([0.2, 0.0, 0.0], (n, 1)))
        rec = simulate_imu(q, dt, frame="NED")
        out = LCF(alpha_mode="tau", tau_s=tau).run_detailed(rec, q0=[1.0, 0.0, 0.0, 0.0]).diagnostics["euler"]
        k = int(round(tau * rate))
        assert out[k - 1, 0] / 0.2 == pytest.approx(1 - np.exp(-1), abs=0.06 if rate == 100.0 else 0.01)
    rec = simulate_imu(quat_from_euler_zyx(_euler_traj(1000)), 0.02, frame="NED", rng=np.random.default_rng(4),
                       gyr_noise=0.01, acc_noise=0.05, mag_noise=0.01)
    truth = _euler_traj(1000)
    stable = CCF(alpha_mode="tau", tau_s=0.2, Kp=500.0, Ki=0.1).run_detailed(rec).diagnostics["euler"]
    rms = np.sqrt(np.mean(wrap(stable - truth)[100:] ** 2))
    assert np.all(np.isfinite(stable)) and rms < 0.2  # follows the noisy acc/mag angles, bounded
    per_sample = CCF(alpha=0.5, Kp=500.0, Ki=0.1).run_detailed(rec).diagnostics["euler"]
    assert np.sqrt(np.mean(wrap(per_sample - truth)[100:] ** 2)) > 0.5  # Kp dt = 10: the seed's update overshoots


def test_alpha_mode_options_are_validated():
    with pytest.raises(ValueError, match="alpha_mode"):
        CCF(alpha_mode="per_second")
    with pytest.raises(ValueError, match="tau_s"):
        LCF(alpha_mode="tau", tau_s=0.0)
    rec = simulate_imu(quat_from_euler_zyx(np.zeros((10, 3))), DT, frame="NED")
    with pytest.raises(ValueError, match="alpha_rate_hz"):
        CCF(alpha_mode="static", alpha_rate_hz=50.0).run(rec)
