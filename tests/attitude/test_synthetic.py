"""Synthetic IMU data and test benches: exactness, statistics, ranges, caches, CSV export."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from objectives.attitude.data import synthetic as syn
from objectives.attitude.data.magnetic import base_waveform, magnetic_perturbation
from objectives.attitude.data.synthetic import (
    PHASES,
    bench6dof,
    csv_columns,
    simulate_imu,
    synthetic,
    tilt1d,
    to_csv,
)

G = 9.81


# ------------------------------------------------------------------------------------------------
# independent references (plain Python / scipy)
# ------------------------------------------------------------------------------------------------
def _ref_qmul(p, q):
    w1, x1, y1, z1 = p
    w2, x2, y2, z2 = q
    return np.array([w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2,
                     w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
                     w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2,
                     w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2])


def _ref_integrate(gyr, dt, q0):
    """q[k+1] = q[k] * exp(gyr[k] dt / 2), one sample at a time."""
    q = np.empty((len(gyr), 4))
    q[0] = q0
    for k in range(len(gyr) - 1):
        v = gyr[k] * dt / 2
        a = math.sqrt(v @ v)
        e = np.array([math.cos(a), *(math.sin(a) / a * v if a > 0 else v)])
        q[k + 1] = _ref_qmul(q[k], e)
    return q


def _scipy_rot(q):
    return Rotation.from_quat(np.column_stack([q[:, 1:], q[:, 0]]))  # scipy is scalar-last


def _smooth_trajectory(n, dt):
    t = np.arange(n) * dt
    rv = np.column_stack([0.6 * np.sin(2 * np.pi * 1.3 * t), 0.4 * np.sin(2 * np.pi * 2.7 * t + 1.0),
                          1.5 * np.sin(2 * np.pi * 0.3 * t)])
    return Rotation.from_rotvec(rv).as_quat()[:, [3, 0, 1, 2]]


# ------------------------------------------------------------------------------------------------
# simulate_imu
# ------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("frame", ["NED", "ENU"])
def test_noise_free_imu_is_exact(frame):
    dt, n = 1e-3, 3000
    q = _smooth_trajectory(n, dt)
    ext = np.column_stack([np.sin(np.arange(n) * dt * 5.0), np.zeros(n), 0.5 * np.ones(n)])
    rec = simulate_imu(q, dt, frame=frame, ext_acc=ext)
    # integrating gyr with the documented rule reproduces the truth
    qi = _ref_integrate(rec.gyr, dt, rec.quat[0])
    assert np.max(np.abs(qi - rec.quat)) < 1e-12
    # the truth is the input rotation (sign-continuous)
    assert np.max(1 - np.abs(np.sum(rec.quat * q, axis=1))) < 1e-14
    # acc and mag rotated to earth give gravity (+g up) + external acceleration and the field
    rot = _scipy_rot(rec.quat)
    up = np.array([0, 0, -1.0]) if frame == "NED" else np.array([0, 0, 1.0])
    np.testing.assert_allclose(rot.apply(rec.acc), G * up + ext, atol=1e-12)
    h = rot.apply(rec.mag)
    np.testing.assert_allclose(np.linalg.norm(h, axis=1), 1.0, atol=1e-13)
    north = np.array([1.0, 0, 0]) if frame == "NED" else np.array([0, 1.0, 0])
    dip = np.degrees(np.arcsin(-(h @ up)))
    np.testing.assert_allclose(dip, syn.DEFAULT_INCLINATION_DEG, atol=1e-9)
    assert np.all(h @ north > 0)
    assert np.array_equal(rec.extra["true_ext_acc"], ext)


def test_constant_rate_closed_form():
    dt, n, w = 2e-3, 500, np.array([0.3, -1.2, 2.0])
    t = np.arange(n) * dt
    q = Rotation.from_rotvec(t[:, None] * w).as_quat()[:, [3, 0, 1, 2]]
    rec = simulate_imu(q, dt)
    np.testing.assert_allclose(rec.gyr, np.broadcast_to(w, (n, 3)), atol=1e-11)


def test_noise_statistics_match_densities():
    dt, n = 1e-3, 200_000
    q = np.tile([1.0, 0, 0, 0], (n, 1))
    dens_g, dens_a, dens_m, walk = 0.01, 0.02, 0.003, 0.05
    rec = simulate_imu(q, dt, rng=np.random.default_rng(1), gyr_noise=dens_g, acc_noise=dens_a,
                       mag_noise=dens_m, gyr_bias=(0.1, -0.2, 0.3), gyr_bias_walk=walk)
    bias = rec.extra["gyr_bias"]
    np.testing.assert_allclose(bias[0], [0.1, -0.2, 0.3])
    white = rec.gyr - bias
    np.testing.assert_allclose(white.std(axis=0), dens_g / math.sqrt(dt), rtol=0.01)
    np.testing.assert_allclose(np.abs(white.mean(axis=0)), 0, atol=4 * dens_g / math.sqrt(dt * n))
    np.testing.assert_allclose(np.diff(bias, axis=0).std(axis=0), walk * math.sqrt(dt), rtol=0.01)
    acc_err = rec.acc - np.array([0, 0, -G])
    np.testing.assert_allclose(acc_err.std(axis=0), dens_a / math.sqrt(dt), rtol=0.01)
    mag_err = rec.mag - syn.earth_field("NED")
    np.testing.assert_allclose(mag_err.std(axis=0), dens_m / math.sqrt(dt), rtol=0.01)
    # white: lag-1 autocorrelation near zero
    x = white[:, 0] - white[:, 0].mean()
    assert abs(np.dot(x[1:], x[:-1]) / np.dot(x, x)) < 0.01


def test_scale_misalignment_and_biases():
    dt, n, w = 1e-3, 200, np.array([0.5, 0.1, -0.3])
    q = Rotation.from_rotvec(np.arange(n)[:, None] * dt * w).as_quat()[:, [3, 0, 1, 2]]
    m = Rotation.from_rotvec([0.01, -0.02, 0.005]).as_matrix()
    rec = simulate_imu(q, dt, gyr_scale=(0.01, -0.02, 0.03), gyr_misalignment=m, acc_bias=(0.1, 0, 0),
                       mag_bias=(0, 0.05, 0))
    expected = np.diag([1.01, 0.98, 1.03]) @ m @ w
    np.testing.assert_allclose(rec.gyr, np.broadcast_to(expected, (n, 3)), atol=1e-10)
    exact = simulate_imu(q, dt)
    np.testing.assert_allclose(rec.acc - exact.acc, np.broadcast_to([0.1, 0, 0], (n, 3)), atol=1e-14)
    np.testing.assert_allclose(rec.mag - exact.mag, np.broadcast_to([0, 0.05, 0], (n, 3)), atol=1e-14)


def test_simulate_imu_validates():
    q = np.tile([1.0, 0, 0, 0], (10, 1))
    with pytest.raises(ValueError, match=r"noise or bias walk requested: pass rng="):
        simulate_imu(q, 0.01, gyr_noise=0.1)
    with pytest.raises(ValueError, match=r"\(N, 4\)"):
        simulate_imu(q[:, :3], 0.01)
    with pytest.raises(ValueError, match="frame"):
        simulate_imu(q, 0.01, frame="XYZ")
    with pytest.raises(ValueError, match="dt must be a positive number of seconds, got -1.0"):
        simulate_imu(q, -1.0)
    with pytest.raises(ValueError, match="gyr_noise"):
        simulate_imu(q, 0.01, gyr_noise=-1.0, rng=np.random.default_rng(0))
    assert simulate_imu(q, 0.01, mag_field=False).mag is None


# ------------------------------------------------------------------------------------------------
# bench6dof
# ------------------------------------------------------------------------------------------------
def _same(a, b):
    return (np.array_equal(a.gyr, b.gyr) and np.array_equal(a.acc, b.acc) and np.array_equal(a.mag, b.mag)
            and np.array_equal(a.quat, b.quat)
            and all(np.array_equal(a.extra[k], b.extra[k]) for k in a.extra))


def test_bench6dof_deterministic_and_seeded():
    state = np.random.get_state()[1].copy()
    a = bench6dof(duration_s=12.0, seed=3)
    b = bench6dof(duration_s=12.0, seed=3)
    c = bench6dof(duration_s=12.0, seed=4)
    assert _same(a, b)
    assert not np.array_equal(a.gyr, c.gyr)
    assert np.array_equal(np.random.get_state()[1], state)  # global RNG untouched


def test_bench6dof_components_are_independent_streams():
    a = bench6dof(duration_s=20.0, seed=5, noise=False)
    b = bench6dof(duration_s=20.0, seed=5, noise=False, mag_perturbation=False)
    assert np.array_equal(a.gyr, b.gyr) and np.array_equal(a.acc, b.acc)
    assert not np.any(b.extra["mag_disturbance"])


@pytest.fixture(scope="module")
def bench():
    return bench6dof(duration_s=80.0, seed=11, noise=False)


def test_bench6dof_has_every_phase(bench):
    codes = set(bench.extra["phase"].astype(int).tolist())
    assert codes == set(range(len(PHASES)))


def test_bench6dof_vibration_frequency_by_fft(bench):
    f = bench.extra["vib_freq_hz"]
    on = f > 0
    assert on.any() and f[on].min() >= 1.0 - 1e-9 and f[on].max() <= 8.0 + 1e-9
    fs, win, nfft = 1000, 2048, 16384
    freqs = np.fft.rfftfreq(nfft, 1 / fs)
    band = (freqs > 0.8) & (freqs < 9.5)
    errors = []
    for start in range(0, bench.n - win, win):
        seg = slice(start, start + win)
        if not np.all(f[seg] > 0):
            continue
        g = bench.gyr[seg] - bench.gyr[seg].mean(axis=0)
        spec = (np.abs(np.fft.rfft(g * np.hanning(win)[:, None], nfft, axis=0)) ** 2).sum(axis=1)
        peak = freqs[band][np.argmax(spec[band])]
        errors.append(abs(peak - f[seg].mean()))
    assert len(errors) >= 5
    assert np.median(errors) < 0.3 and np.mean(np.array(errors) < 0.6) >= 0.8


def test_bench6dof_external_acceleration(bench):
    ext = bench.extra["true_ext_acc"]
    assert np.abs(ext).max() <= 2.0 * G + 1e-9          # default ext_acc_max_g = 2
    assert np.abs(ext).max() > 1.0 * G                  # and it gets there
    codes = bench.extra["phase"].astype(int)
    acc_phase = np.array([PHASES[c][2] for c in codes])
    # no external acceleration well inside phases without it (0.5 s ramps)
    far = np.convolve(acc_phase.astype(float), np.ones(1001), mode="same") == 0
    assert far.any() and np.all(ext[far] == 0)
    # specific force rotated to earth = +g up + external acceleration
    up = np.array([0, 0, -G])
    np.testing.assert_allclose(_scipy_rot(bench.quat).apply(bench.acc), up + ext, atol=1e-9)
    rate = np.abs(bench.extra["true_gyr"]).max()
    assert 5.0 < rate < 50.0                            # paper: +-50 rad/s


def test_bench6dof_magnetic_perturbation_sections(bench):
    d = bench.extra["mag_disturbance"]
    codes = bench.extra["phase"].astype(int)
    mag_phase = np.array([PHASES[c][3] for c in codes])
    assert np.all(d[~mag_phase] == 0) and np.abs(d[mag_phase]).max() > 0.3
    assert np.linalg.norm(d, axis=1).max() <= 5.0 + 1e-9
    field = _scipy_rot(bench.quat).inv().apply(syn.earth_field("NED"))
    np.testing.assert_allclose(bench.mag - d, field, atol=1e-12)


def test_bench6dof_rejects_unknown_keyword():
    with pytest.raises(ValueError, match="allowed sensor keywords"):
        bench6dof(duration_s=1.0, gyro_noise=0.1)


def test_bench6dof_160s_is_fast():
    import time
    bench6dof(duration_s=2.0)
    t0 = time.perf_counter()
    rec = bench6dof(duration_s=160.0, rate_hz=1000.0, seed=1)
    assert rec.n == 160_000
    assert time.perf_counter() - t0 < 3.0


# ------------------------------------------------------------------------------------------------
# tilt1d
# ------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("frame", ["NED", "ENU"])
def test_tilt1d_exact_geometry(frame):
    rec = tilt1d(duration_s=30.0, seed=2, noise=False, frame=frame)
    assert rec.rate_hz == 800.0 and rec.mag is None
    a, ext = rec.extra["angle"], rec.extra["true_ext_acc"]
    # rotation about y only; gyr_y integrates to the angle exactly
    assert np.all(rec.gyr[:, [0, 2]] == 0)
    integrated = a[0] + np.concatenate([[0], np.cumsum(rec.gyr[:-1, 1]) * rec.dt])
    np.testing.assert_allclose(integrated, a, atol=1e-10)
    truth = np.column_stack([np.cos(a / 2), 0 * a, np.sin(a / 2), 0 * a])
    np.testing.assert_allclose(rec.quat, truth, atol=1e-15)
    # external acceleration horizontal along earth x only, within 1.5 g and reaching above 0.75 g
    assert np.all(ext[:, 1:] == 0) and np.abs(ext[:, 0]).max() <= 1.5 * G + 1e-9
    assert np.abs(ext[:, 0]).max() > 0.75 * G
    # acc magnitude and the accelerometer tilt
    np.testing.assert_allclose(np.linalg.norm(rec.acc, axis=1), np.hypot(G, ext[:, 0]), rtol=1e-12)
    assert np.all(rec.acc[:, 1] == 0)
    still = ext[:, 0] == 0
    if frame == "NED":
        tilt = np.arctan2(rec.acc[:, 0], -rec.acc[:, 2])
    else:
        tilt = np.arctan2(-rec.acc[:, 0], rec.acc[:, 2])
    np.testing.assert_allclose(tilt[still], a[still], atol=1e-12)
    # thesis ranges: oscillation within 0-6.5 Hz, rate within 800 deg/s
    f = rec.extra["vib_freq_hz"]
    assert f.max() <= 6.5 + 1e-9 and f.max() > 3.0
    assert np.abs(rec.gyr[:, 1]).max() <= math.radians(800.0)


def test_tilt1d_noise_model():
    rec = tilt1d(duration_s=20.0, seed=9)
    exact = tilt1d(duration_s=20.0, seed=9, noise=False)
    lsb = 0.018 * G
    np.testing.assert_allclose(rec.acc / lsb, np.round(rec.acc / lsb), atol=1e-9)   # 8-bit quantisation
    assert np.abs(rec.acc).max() <= 2 * G + 1e-9
    gyr_err = rec.gyr - exact.gyr - rec.extra["gyr_bias"]
    expected_std = syn.TILT1D_SENSOR["gyr_noise"] * math.sqrt(800)
    np.testing.assert_allclose(gyr_err.std(axis=0), expected_std, rtol=0.03)
    assert np.all(np.abs(rec.extra["gyr_bias"][0]) <= syn.TILT1D_SENSOR["gyr_bias_max"])
    assert _same(rec, tilt1d(duration_s=20.0, seed=9))


# ------------------------------------------------------------------------------------------------
# magnetic perturbation (FAEKF eq. 34)
# ------------------------------------------------------------------------------------------------
def _ref_eq34(m, dt, cutoff_hz, amplitude):
    """Independent eq. 34: FFT analytic signal, reversed magnitude, least-squares detrend,
    first-order Butterworth by the bilinear transform, sample by sample."""
    n = len(m)
    h = np.zeros(n)
    h[0] = 1
    if n % 2 == 0:
        h[n // 2] = 1
        h[1:n // 2] = 2
    else:
        h[1:(n + 1) // 2] = 2
    ma = np.fft.ifft(np.fft.fft(m) * h)
    mp = ma.imag + np.abs(ma)[::-1]
    k = np.arange(n)
    mp = mp - np.polyval(np.polyfit(k, mp, 1), k)
    if cutoff_hz is not None:
        K = math.tan(math.pi * cutoff_hz * dt)
        b0, a1 = K / (1 + K), (K - 1) / (K + 1)
        y = np.empty(n)
        prev_x = prev_y = 0.0
        for i in range(n):
            y[i] = b0 * mp[i] + b0 * prev_x - a1 * prev_y
            prev_x, prev_y = mp[i], y[i]
        mp = y
    return mp * amplitude / np.abs(mp).max()


@pytest.mark.parametrize("cutoff", [None, 1.0])
def test_magnetic_perturbation_matches_reference(cutoff):
    n, dt = 4000, 1e-3
    got = magnetic_perturbation(n, dt, np.random.default_rng(5), axes=1, amplitude=2.5,
                                cutoff_hz=cutoff)
    m = base_waveform(n, dt, np.random.default_rng(5))
    np.testing.assert_allclose(got, _ref_eq34(m, dt, cutoff, 2.5), atol=1e-9)
    assert np.abs(got).max() == pytest.approx(2.5)


def test_magnetic_perturbation_detrended_and_low_passed():
    n, dt = 20000, 1e-3
    raw = magnetic_perturbation(n, dt, np.random.default_rng(8), axes=3, cutoff_hz=None)
    low = magnetic_perturbation(n, dt, np.random.default_rng(8), axes=3, cutoff_hz=1.0)
    k = np.arange(n)
    for j in range(3):
        slope, icpt = np.polyfit(k, raw[:, j], 1)
        assert abs(slope) * n < 1e-9 and abs(icpt) < 1e-9      # no linear trend left
    freqs = np.fft.rfftfreq(n, dt)

    def high_fraction(x):
        p = np.abs(np.fft.rfft(x - x.mean(axis=0), axis=0)) ** 2
        return p[freqs > 20].sum() / p.sum()

    assert high_fraction(low) < 0.05 * high_fraction(raw)
    assert np.linalg.norm(low, axis=1).max() == pytest.approx(1.0)
    with pytest.raises(ValueError, match="cutoff_hz"):
        magnetic_perturbation(n, dt, np.random.default_rng(0), cutoff_hz=600.0)


# ------------------------------------------------------------------------------------------------
# dispatcher, caches, CSV
# ------------------------------------------------------------------------------------------------
def test_synthetic_dispatch_and_memory_cache():
    a = synthetic("tilt1d", duration_s=3.0, seed=1, disk_cache=False)
    assert synthetic("tilt1d", seed=1, duration_s=3.0, disk_cache=False) is a
    assert _same(a, tilt1d(duration_s=3.0, seed=1))
    b = synthetic("bench6dof", duration_s=3.0, vib_freq_range_hz=[2.0, 4.0], disk_cache=False)
    assert b is synthetic("bench6dof", duration_s=3.0, vib_freq_range_hz=(2.0, 4.0), disk_cache=False)
    with pytest.raises(ValueError, match="allowed: bench6dof, tilt1d"):
        synthetic("bench9dof")
    with pytest.raises(ValueError, match="allowed:.*duration_s"):
        synthetic("tilt1d", durration_s=3.0)


def test_synthetic_disk_cache(tmp_path, monkeypatch):
    monkeypatch.setenv("TUNER_CACHE", str(tmp_path))
    a = synthetic("bench6dof", duration_s=2.5, seed=7)
    files = list(tmp_path.glob("synthetic-bench6dof-*.npz"))
    assert len(files) == 1
    syn._cached.cache_clear()
    b = synthetic("bench6dof", duration_s=2.5, seed=7)
    assert b is not a and _same(a, b)
    assert (b.frame, b.name, dict(b.units), b.dt) == (a.frame, a.name, dict(a.units), a.dt)


def test_csv_round_trip(tmp_path):
    rec = bench6dof(duration_s=0.5, seed=2)
    path = to_csv(rec, tmp_path / "bench.csv")
    header = path.read_text().splitlines()[0].split(",")
    assert header == csv_columns(rec)
    assert header[:15] == ["t", "gyr_x", "gyr_y", "gyr_z", "acc_x", "acc_y", "acc_z", "mag_x", "mag_y",
                           "mag_z", "q_w", "q_x", "q_y", "q_z", "motion"]
    assert "true_ext_acc_x" in header and "vib_freq_hz" in header and "mag_disturbance_z" in header
    data = np.loadtxt(path, delimiter=",", skiprows=1)
    col = {c: i for i, c in enumerate(header)}
    assert np.array_equal(data[:, col["t"]], rec.time)
    assert np.array_equal(data[:, [col["gyr_x"], col["gyr_y"], col["gyr_z"]]], rec.gyr)
    assert np.array_equal(data[:, [col["acc_x"], col["acc_y"], col["acc_z"]]], rec.acc)
    assert np.array_equal(data[:, [col["mag_x"], col["mag_y"], col["mag_z"]]], rec.mag)
    assert np.array_equal(data[:, col["q_w"]:col["q_z"] + 1], rec.quat)
    assert np.array_equal(data[:, col["vib_freq_hz"]], rec.extra["vib_freq_hz"])
    assert np.array_equal(data[:, col["motion"]], rec.motion.astype(float))
