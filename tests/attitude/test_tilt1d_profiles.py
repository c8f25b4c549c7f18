"""The tilt bench's ``thesis`` profile against what thesis 3.1.2 states, and its options' validation."""

from __future__ import annotations

import math

import numpy as np
import pytest

from benchmarks.tilt_bench import accelerometer_tilt, bench_stats, gyro_drift_deg
from objectives.attitude.data.tilt1d import TILT1D_PROFILES, tilt1d
from objectives.attitude.quaternion import qrot_batch

G = 9.81


def _same(a, b) -> bool:
    return all(np.array_equal(getattr(a, k), getattr(b, k)) for k in ("gyr", "acc", "quat")) and \
        all(np.array_equal(a.extra[k], b.extra[k]) for k in a.extra)


def test_default_profile_is_the_bench_as_first_written():
    kw = dict(duration_s=12.0, rate_hz=200.0, seed=3)
    base = tilt1d(**kw)
    assert _same(base, tilt1d(**kw, profile="default"))
    assert _same(base, tilt1d(**kw, lever_arm_m=0.0, start_at_rest=False))
    assert "lever_acc" not in base.extra


@pytest.mark.parametrize("frame", ["NED", "ENU"])
def test_lever_arm_adds_the_rotating_point_acceleration(frame):
    """Independent reference: the sensor's earth-frame position ``L R(q) u`` differentiated twice, rotated
    into the sensor frame; in closed form ``L theta''`` along x times the up axis' sign and ``-L theta'^2``
    along the up axis."""
    kw = dict(duration_s=20.0, rate_hz=800.0, seed=4, noise=False, external_acc=False, frame=frame)
    lever = 0.03
    rec, ref = tilt1d(**kw, lever_arm_m=lever), tilt1d(**kw)
    up = np.array([0.0, 0.0, -1.0 if frame == "NED" else 1.0])
    pos = lever * qrot_batch(rec.quat, np.tile(up, (rec.n, 1)))
    acc_earth = np.gradient(np.gradient(pos, rec.dt, axis=0), rec.dt, axis=0)
    acc_sensor = qrot_batch(rec.quat, acc_earth, inverse=True)
    diff = rec.acc - ref.acc
    inner = slice(4, -4)
    scale = np.abs(acc_sensor[inner]).max()
    assert scale > 5.0  # the oscillation makes the lever arm felt (m/s^2)
    np.testing.assert_allclose(diff[inner], acc_sensor[inner], atol=2e-3 * scale)
    rate = np.gradient(rec.extra["angle"], rec.dt)  # central differences: true_gyr is the rate held over a sample
    tangential = lever * np.gradient(rate, rec.dt)
    np.testing.assert_allclose(diff[inner, 0] * up[2], tangential[inner], atol=2e-3 * scale)
    np.testing.assert_allclose(diff[inner, 2] * up[2], -lever * rate[inner] ** 2, atol=2e-3 * scale)
    np.testing.assert_allclose(rec.extra["lever_acc"], rec.extra["true_ext_acc"], atol=0)


def test_thesis_profile_matches_section_3_1_2():
    """3.1.2.2: oscillation 0-6.5 Hz, +-800 deg/s, +-1.5 g horizontal; drift about 15 deg / 100 s and 40 deg /
    300 s; 3.1.4.3: the packet mean of the dynamic acceleration reaches about 0.35 g; the accelerometer
    tilt is accurate at rest and degrades "drastically" with acceleration or high angular velocity."""
    rec = tilt1d(duration_s=350.0, seed=1, profile="thesis")
    st = bench_stats(rec)
    assert st["f_max_hz"] <= 6.5 and st["fhat_max_hz"] <= 6.5
    assert 700.0 < st["rate_max_dps"] <= 800.0
    assert 1.0 < st["ext_max_g"] <= 1.5
    assert 10.0 <= abs(st["drift100_deg"]) <= 20.0 and 30.0 <= abs(st["drift300_deg"]) <= 50.0
    assert 0.25 <= st["ahat_max_g"] <= 0.5
    assert st["acc_mse_static"] < 10.0 and st["acc_mse_calm"] < 10.0
    for phase in ("vibrating", "accelerating", "vib+acc"):
        assert st[f"acc_mse_{phase}"] > 20 * st["acc_mse_static"], phase
    # the default bench (sensor on the axle) leaves vibration harmless to the accelerometer tilt
    assert bench_stats(tilt1d(duration_s=60.0, seed=1))["acc_mse_vibrating"] < 10.0


@pytest.mark.parametrize("seed", [2, 3, 4, 5])
def test_thesis_profile_starts_at_rest(seed):
    rec = tilt1d(duration_s=30.0, seed=seed, profile="thesis")
    first = rec.extra["phase"] == rec.extra["phase"][0]
    assert rec.extra["phase"][0] == 0
    k = int(np.argmin(first)) // 2  # well inside the first phase, before the ramp to the next one
    assert np.ptp(rec.extra["angle"][:k]) == 0.0
    err = np.degrees(accelerometer_tilt(rec)[:k] - rec.extra["angle"][:k])
    assert np.sqrt(np.mean(err ** 2)) < 1.5  # only noise and the 18 mg quantisation


def test_gyro_bias_magnitude_option():
    rec = tilt1d(duration_s=5.0, seed=7, gyr_bias_dps=0.14)
    drawn = tilt1d(duration_s=5.0, seed=7)
    b0, d0 = rec.extra["gyr_bias"][0, 1], drawn.extra["gyr_bias"][0, 1]
    assert math.isclose(abs(b0), math.radians(0.14), rel_tol=1e-12) and np.sign(b0) == np.sign(d0)
    np.testing.assert_array_equal(rec.extra["gyr_bias"][:, [0, 2]], drawn.extra["gyr_bias"][:, [0, 2]])
    assert gyro_drift_deg(tilt1d(duration_s=5.0, seed=7, noise=False), 4.0) == 0.0
    assert math.isnan(gyro_drift_deg(rec, 100.0))


@pytest.mark.parametrize("kw, key", [
    ({"profile": "thesys"}, "profile"),
    ({"lever_arm_m": -0.01}, "lever_arm_m"),
    ({"lever_arm_m": float("nan")}, "lever_arm_m"),
    ({"lever_arm_m": True}, "lever_arm_m"),
    ({"profile": ["thesis"]}, "profile"),
    ({"gyr_bias_dps": -1.0}, "gyr_bias_dps"),
    ({"start_at_rest": "yes"}, "start_at_rest"),
])
def test_bad_profile_options_are_named(kw, key):
    with pytest.raises(ValueError, match=key):
        tilt1d(duration_s=1.0, **kw)


def test_profiles_are_complete():
    assert set(TILT1D_PROFILES) == {"default", "thesis"}
    for values in TILT1D_PROFILES.values():
        assert set(values) == {"lever_arm_m", "gyr_bias_dps", "start_at_rest"}
