"""The ``realtime`` filter: kernel against the slow reference (PyVQF with the project's additions), against
VQF's compiled core on BROAD, unit norm, split/resume, rate independence and accuracy on synthetic benches."""

from __future__ import annotations

import numpy as np
import pytest

from objectives.attitude.data.recording import Recording
from objectives.attitude.filters import get_filter
from objectives.attitude.filters.realtime import Realtime
from objectives.attitude.filters.realtime.coefficients import STATE_LEN
from objectives.attitude.filters.realtime.kernel import realtime_kernel
from objectives.attitude.metrics import broad_errors

G_UP = np.array([0.0, 0.0, 9.81])
M_ENU = np.array([0.0, 20.0, -40.0])  # north and down, uT


def _qmul(a, b):
    w1, x1, y1, z1 = a.T
    w2, x2, y2, z2 = b.T
    return np.stack([w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2, w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
                     w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2, w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2], axis=-1)


def _rot_to_sensor(q, v):
    """``q* v q`` (earth vector in the sensor frame) for (N, 4) ``q`` (sensor-to-ENU)."""
    from scipy.spatial.transform import Rotation as R

    return R.from_quat(q[:, [1, 2, 3, 0]]).inv().apply(v)


def scenario(rate_hz: float = 100.0, seed: int = 3, duration_s: float = 40.0, disturb: bool = True,
             bias_dps=(0.4, -0.3, 0.2)) -> Recording:
    """Rest (8 s), rotation about changing axes, a magnet near the sensor (a sensor-frame field offset,
    14-22 s when ``disturb``), rotation, rest; constant gyro bias, white noise; exact truth (ENU)."""
    rng = np.random.default_rng(seed)
    dt = 1.0 / rate_hz
    t = np.arange(int(duration_s * rate_hz)) * dt
    w = np.zeros((t.size, 3))
    moving = (t > 8.0) & (t < duration_s - 6.0)
    w[moving] = np.stack([1.2 * np.sin(0.7 * t), 0.9 * np.cos(0.45 * t), 0.8 * np.sin(0.3 * t + 1.0)], 1)[moving]
    q = np.empty((t.size, 4))
    q[0] = (np.cos(0.3), np.sin(0.3) * 0.6, 0.0, np.sin(0.3) * 0.8)
    for i in range(1, t.size):  # exact integration of the piecewise-constant rate
        n = np.linalg.norm(w[i])
        dq = np.array([1.0, 0, 0, 0]) if n == 0 else np.r_[np.cos(n * dt / 2), np.sin(n * dt / 2) * w[i] / n]
        q[i] = _qmul(q[i - 1][None], dq[None])[0]
    acc = _rot_to_sensor(q, G_UP) + 0.02 * rng.standard_normal((t.size, 3))
    mag = _rot_to_sensor(q, M_ENU) + 0.2 * rng.standard_normal((t.size, 3))
    if disturb:
        mag[(t > 14.0) & (t < 22.0)] += (15.0, -10.0, 8.0)
    gyr = w + np.radians(bias_dps) + 0.002 * rng.standard_normal((t.size, 3))
    return Recording("scenario", gyr, acc, mag, dt, quat=q, frame="ENU")


OPTION_SETS = {
    "defaults": {},
    "additions": {"mag_first_at_rest": True, "mag_recover_tau_s": 2.0, "tau_acc_s": 1.5, "tau_mag_s": 20.0},
    "blocks_off": {"motion_bias": False, "rest_bias": False, "mag_rejection": False},
    "no_motion_bias": {"motion_bias": False, "mag_first_at_rest": True, "mag_current_tau_s": 0.0},
}


@pytest.mark.parametrize("use_mag", [True, False], ids=["9d", "6d"])
@pytest.mark.parametrize("opts", list(OPTION_SETS), ids=list(OPTION_SETS))
def test_kernel_matches_slow_reference(opts, use_mag):
    pytest.importorskip("vqf")
    from tests.reference.realtime_reference import reference_run

    rec = scenario(duration_s=30.0)
    values = {**OPTION_SETS[opts], "use_mag": use_mag}
    res = Realtime(**values).run_detailed(rec)
    ref = reference_run({**Realtime.defaults, **values}, rec.gyr, rec.acc, rec.mag if use_mag else None, rec.dt)
    np.testing.assert_allclose(res.quat, ref["quat"], atol=1e-9, rtol=0)
    np.testing.assert_allclose(res.diagnostics["bias"], ref["bias"], atol=1e-11, rtol=0)
    np.testing.assert_array_equal(res.diagnostics["rest"], ref["rest"])
    if use_mag:
        np.testing.assert_array_equal(res.diagnostics["mag_dist"], ref["mag_dist"])
    # the scenario exercises every block: rest detected, a disturbance detected
    if opts != "blocks_off":
        assert res.diagnostics["rest"].any() and (~res.diagnostics["rest"]).any()
    if use_mag and opts != "blocks_off":
        assert res.diagnostics["mag_dist"][int(18.0 / rec.dt)]


def test_defaults_equal_vqf_core_on_broad():
    vqf = pytest.importorskip("vqf")
    from objectives.attitude.data.broad import default_broad_dir, load_broad

    path = default_broad_dir() / "32_disturbed_attached_magnet_1cm.mat"
    if not path.exists():
        pytest.skip("needs ../shared/data/broad")
    rec = load_broad(path)
    n = 20000
    sub = Recording("head", rec.gyr[:n], rec.acc[:n], rec.mag[:n], rec.dt, quat=rec.quat[:n], frame=rec.frame)
    q = Realtime().run_detailed(sub).quat
    o = vqf.VQF(rec.dt).updateBatch(np.ascontiguousarray(sub.gyr), np.ascontiguousarray(sub.acc),
                                   np.ascontiguousarray(sub.mag))
    from objectives.attitude.quaternion import to_frame

    np.testing.assert_allclose(q, to_frame(o["quat9D"], "ENU", rec.frame), atol=1e-10, rtol=0)


def test_unit_norm_and_finite_on_hard_input():
    rec = scenario(rate_hz=200.0, seed=5)
    rng = np.random.default_rng(0)
    acc = rec.acc + rng.normal(0.0, 20.0, rec.acc.shape)  # accelerations up to several g
    acc[100:110] = 0.0  # unusable samples are skipped
    mag = rec.mag.copy()
    mag[500:520] = 0.0
    hard = Recording("hard", rec.gyr * 5.0, acc, mag, rec.dt, quat=rec.quat, frame="ENU")
    for values in OPTION_SETS.values():
        q = Realtime(**values).run(hard)
        assert np.isfinite(q).all()
        np.testing.assert_allclose(np.linalg.norm(q, axis=1), 1.0, atol=1e-12)


def test_split_run_resumes_from_state():
    rec = scenario(duration_s=25.0)
    f = Realtime(mag_first_at_rest=True, mag_recover_tau_s=3.0)
    c = f.kernel_setup(rec.dt, True, np.array([1.0, 0.0, 0.0, 0.0]), "ENU").coef
    n = rec.gyr.shape[0]
    outs = []
    for parts in ([slice(0, n)], [slice(0, 1234), slice(1234, n)]):
        s = f.kernel_setup(rec.dt, True, np.array([1.0, 0.0, 0.0, 0.0]), "ENU").state  # start: self, the identity
        assert s.shape == (STATE_LEN,)
        q = np.empty((n, 4))
        for sl in parts:
            m = sl.stop - sl.start
            o, b, fl = np.empty((m, 4)), np.empty((m, 3)), np.empty((m, 3))
            realtime_kernel(rec.gyr[sl].copy(), rec.acc[sl].copy(), rec.mag[sl].copy(), c, s, o, b, fl)
            q[sl] = o
        outs.append(q)
    np.testing.assert_array_equal(outs[0], outs[1])


def _rmse(rec, **values):
    q = Realtime(**values).run(rec)
    return broad_errors(q, rec.quat, rec.motion).total_rmse_deg


def test_accurate_on_scenario_and_additions_help_with_a_magnet_at_start():
    assert _rmse(scenario(duration_s=40.0, disturb=False)) < 0.5  # measured 0.11 deg
    rec = scenario(duration_s=40.0)
    # VQF's rule learns no field at rest: the magnet near the sensor after 8 s of rest is learnt as the field
    # (measured 5.2 deg; without rejection 10.1)
    base = _rmse(rec)
    assert base < _rmse(rec, mag_rejection=False)
    # the field is known from the first rest when the first field is accepted at rest: the magnet is then
    # rejected instead of learnt as the reference (measured 0.14 deg)
    ours = _rmse(rec, mag_first_at_rest=True)
    assert ours < 0.5 < base


@pytest.mark.parametrize("rate_hz", [50.0, 100.0, 400.0, 1000.0])
def test_rate_independent_on_scenario(rate_hz):
    """The same values at every rate: time constants in s make the error nearly rate-independent."""
    values = {"mag_first_at_rest": True, "tau_acc_s": 2.0, "tau_mag_s": 10.0}
    ref = _rmse(scenario(rate_hz=200.0), **values)
    got = _rmse(scenario(rate_hz=rate_hz), **values)
    assert abs(got - ref) < 0.25 * ref + 0.05, (rate_hz, got, ref)


def test_bench6dof_1khz_bounded():
    from objectives.attitude.data.synthetic import synthetic

    rec = synthetic("bench6dof", duration_s=20, rate_hz=1000, seed=2)
    err = broad_errors(Realtime(mag_first_at_rest=True).run(rec), rec.quat, rec.motion).total_rmse_deg
    assert np.isfinite(err) and err < 10.0


def test_registered_and_validated():
    assert get_filter("realtime") is Realtime
    with pytest.raises(ValueError, match="tau_acc_s"):
        Realtime(tau_acc_s=-1.0)
    with pytest.raises(ValueError, match="mag_rejection_factor"):
        Realtime(mag_rejection_factor=0.5)
    with pytest.raises(ValueError, match="dt"):
        Realtime().kernel_setup(0.0, True, np.array([1.0, 0.0, 0.0, 0.0]), "ENU")
    assert {"tau_acc_s", "tau_mag_s"} <= set(Realtime.space().free_names)


def test_stream_from_q0_equals_batch():
    rec = scenario(duration_s=12.0)
    f = Realtime(start="q0", mag_first_at_rest=True)
    q0 = np.array([0.9, 0.1, -0.2, 0.3]) / np.linalg.norm([0.9, 0.1, -0.2, 0.3])
    want = f.run(rec.gyr, rec.acc, rec.mag, dt=rec.dt, q0=q0)
    s = f.stream(dt=rec.dt, q0=q0)
    got = np.array([s.update(g, a, m) for g, a, m in zip(rec.gyr, rec.acc, rec.mag)])
    np.testing.assert_array_equal(got, want)
    assert not np.allclose(want[:50], Realtime(mag_first_at_rest=True).run(rec)[:50])  # the start is used


def disturbed_start(rate_hz: float = 100.0, seed: int = 4, moving_s: float = 12.0, rest_s: float = 50.0,
                    never_rest: bool = False) -> Recording:
    """A slow yaw (5 deg/s: motion for the rest detector, below mag_new_min_gyr_dps) for ``moving_s`` in a field
    disturbed by an earth-fixed offset (steel nearby: norm and dip stable while turning, dip 20 deg off, the
    horizontal field 51 deg off north), then at rest in the undisturbed field (``never_rest``: still turning)."""
    rng = np.random.default_rng(seed)
    dt = 1.0 / rate_hz
    t = np.arange(int((moving_s + rest_s) * rate_hz)) * dt
    turning = np.full(t.size, True) if never_rest else t < moving_s
    w = np.zeros((t.size, 3))
    w[turning, 2] = np.radians(5.0)
    q = np.empty((t.size, 4))
    q[0] = (1.0, 0.0, 0.0, 0.0)
    for i in range(1, t.size):
        n = np.linalg.norm(w[i])
        dq = np.array([1.0, 0, 0, 0]) if n == 0 else np.r_[np.cos(n * dt / 2), np.sin(n * dt / 2) * w[i] / n]
        q[i] = _qmul(q[i - 1][None], dq[None])[0]
    field = np.tile(M_ENU, (t.size, 1))
    field[t < moving_s] += (25.0, 0.0, 10.0)
    acc = _rot_to_sensor(q, G_UP) + 0.02 * rng.standard_normal((t.size, 3))
    mag = np.array([_rot_to_sensor(q[i:i + 1], field[i])[0] for i in range(t.size)]) + \
        0.2 * rng.standard_normal((t.size, 3))
    gyr = w + 0.002 * rng.standard_normal((t.size, 3))
    return Recording("disturbed_start", gyr, acc, mag, dt, quat=q, frame="ENU")


def _flags(rec, **values):
    """Quaternions and the kernel's flags (rest, magnetic disturbance, delta) of a run from the identity."""
    f = Realtime(**values)
    setup = f.kernel_setup(rec.dt, True, np.array([1.0, 0.0, 0.0, 0.0]), "ENU")
    n = rec.gyr.shape[0]
    q, b, fl = np.empty((n, 4)), np.empty((n, 3)), np.empty((n, 3))
    realtime_kernel(rec.gyr.copy(), rec.acc.copy(), rec.mag.copy(), setup.coef, setup.state, q, b, fl)
    return q, fl


def _angle_deg(a, b):
    return np.degrees(2.0 * np.arccos(np.clip(np.abs(np.sum(a * b, axis=1)), 0.0, 1.0)))


def test_first_field_at_rest_waits_for_rest():
    """Started while moving in a disturbed but stable field, the filter learns the field once at rest in the
    undisturbed one (measured: 0.5 deg at the end); accepting the first stable field whatever the motion, as
    the option once did, learnt the disturbed one (41 deg after 30 s, 9.2 deg at the end)."""
    rec = disturbed_start()
    q, fl = _flags(rec, mag_first_at_rest=True)
    t = np.arange(rec.gyr.shape[0]) * rec.dt
    assert fl[t < 12.0, 0].max() == 0.0 and fl[t > 16.0, 0].min() == 1.0  # moving, then at rest
    assert fl[(t > 1.0) & (t < 12.0), 1].min() == 1.0  # no field accepted while moving slowly
    assert fl[t > 25.0, 1].max() == 0.0  # the undisturbed field, learnt at rest, is the reference
    assert _angle_deg(q, rec.quat)[t > t[-1] - 5.0].max() < 3.0
    # VQF's own rule (no first field at rest) learns nothing here either: it never rotates fast enough
    q_vqf, fl_vqf = _flags(rec)
    assert fl_vqf[t > 1.0, 1].min() == 1.0


def test_first_field_at_rest_never_at_rest_falls_back_to_rotation():
    """Never at rest and never rotating faster than mag_new_min_gyr_dps: no field is accepted (the disturbance
    flag stays on); the heading keeps its fast start and the gyro (the documented fallback)."""
    rec = disturbed_start(never_rest=True, moving_s=0.0, rest_s=40.0)
    q, fl = _flags(rec, mag_first_at_rest=True)
    assert fl[:, 0].max() == 0.0 and fl[100:, 1].min() == 1.0
    assert _angle_deg(q, rec.quat)[-500:].max() < 2.0
