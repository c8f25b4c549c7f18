"""objectives.attitude.disturbance against closed forms and the literal eqs. 3.19-3.22."""


import numpy as np
import pytest

from objectives.attitude import disturbance as dis
from tests.reference.tilt1d_reference import packet_mean_ref, vibration_ref

DT = 1e-3


@pytest.mark.parametrize("f0", [0.7, 2.0, 3.3, 5.3, 7.9])
def test_sinusoid_frequency_within_one_bin(f0):
    t = np.arange(4000) * DT
    rng = np.random.default_rng(int(f0 * 10))
    gyr = 1.5 * np.sin(2 * np.pi * f0 * t + rng.uniform(0, 6)) + 0.01 * rng.standard_normal(t.size)
    f = dis.vibration_frequency(gyr, DT, 400, 512, omega_thr=0.26, f_thr=10.0)
    bin_hz = 1.0 / (512 * DT)
    assert np.all(f[:400] == 0.0)  # causal: nothing known during the first packet
    assert np.all(np.abs(f[400:] - f0) <= bin_hz)
    assert np.allclose(f[400:] / bin_hz, np.round(f[400:] / bin_hz))  # on the bin grid


def test_thresholds_and_axis_selection():
    t = np.arange(2000) * DT
    small = 0.1 * np.sin(2 * np.pi * 3.0 * t)
    assert np.all(dis.vibration_frequency(small, DT, omega_thr=0.26) == 0.0)  # below |Omega|_thr
    fast = 2.0 * np.sin(2 * np.pi * 40.0 * t)  # above f_thr: ignored, only the small 3 Hz is seen
    assert np.all(dis.vibration_frequency(fast + small, DT, omega_thr=0.26, f_thr=10.0) == 0.0)
    g3 = np.stack([small, 2.0 * np.sin(2 * np.pi * 6.0 * t), np.zeros_like(t)], axis=1)
    both = dis.vibration_frequency(g3, DT, omega_thr=0.05)
    only_x = dis.vibration_frequency(g3, DT, omega_thr=0.05, axis=0)
    assert abs(both[-1] - 6.0) <= 1.0 / (512 * DT) and abs(only_x[-1] - 3.0) <= 1.0 / (512 * DT)
    nc = dis.vibration_frequency(g3, DT, omega_thr=0.05, causal=False)
    np.testing.assert_array_equal(nc[:400], both[400:800])  # non-causal: no packet delay


def test_vibration_matches_literal_dft():
    rng = np.random.default_rng(7)
    t = np.arange(1100) * DT
    x = 0.8 * np.sin(2 * np.pi * 4.1 * t) + 0.3 * rng.standard_normal(t.size)
    ref = vibration_ref(x, DT, 200, 256, 0.2, 15.0)
    got = dis.vibration_frequency(x, DT, 200, 256, 0.2, f_thr=15.0)
    np.testing.assert_array_equal(got, ref)


def _static_acc(n=3000, tilt=0.4, g=9.81):
    return np.tile([g * np.sin(tilt), 0.0, g * np.cos(tilt)], (n, 1))


@pytest.mark.parametrize("mode", ["packet", "sliding"])
def test_zero_on_static_recording(mode):
    acc = _static_acc()
    assert np.max(dis.external_acceleration(acc, 400, mode=mode)) < 1e-14
    mag = np.tile([0.2, -0.1, 0.45], (3000, 1))
    assert np.max(dis.magnetic_perturbation_measure(mag, 400, mode=mode)) < 1e-14
    assert np.all(dis.vibration_frequency(np.zeros((3000, 3)), DT) == 0.0)


def test_external_acceleration_values():
    acc = _static_acc(2000)
    acc[400:800, 0] += 3.0  # packet 1 has |a| - g = d at every sample
    d = np.linalg.norm(acc[500]) - 9.81
    out = dis.external_acceleration(acc, 400)
    np.testing.assert_allclose(out[800:1200], d / 9.81, rtol=1e-12)
    assert np.max(np.abs(out[:800])) < 1e-14 and np.max(np.abs(out[1200:])) < 1e-14
    x = np.abs(np.linalg.norm(acc, axis=1) - 9.81) / 9.81
    np.testing.assert_allclose(out, packet_mean_ref(x, 400), atol=1e-15)
    # sliding: trailing mean over min(k + 1, L) samples
    sl = dis.external_acceleration(acc, 400, mode="sliding")
    cs = np.concatenate([[0.0], np.cumsum(x)])
    k = np.arange(acc.shape[0])
    lo = np.maximum(0, k - 399)
    np.testing.assert_allclose(sl, (cs[k + 1] - cs[lo]) / (k + 1 - lo), atol=1e-13)
    # the trailing partial packet holds the last complete packet's value
    out2 = dis.external_acceleration(acc[:1000], 400)
    np.testing.assert_allclose(out2[800:], d / 9.81, rtol=1e-12)


def test_magnetic_measure_reference_norm():
    mag = np.tile([0.0, 0.6, 0.8], (1200, 1))
    mag[400:800] *= 1.5
    out = dis.magnetic_perturbation_measure(mag, 400)  # median norm = 1
    np.testing.assert_allclose(out[800:1200], 0.5, rtol=1e-12)
    out2 = dis.magnetic_perturbation_measure(mag, 400, ref_norm=2.0)
    np.testing.assert_allclose(out2[400:800], 0.5, rtol=1e-12)  # packet 0: |1 - 2| / 2


def test_validation():
    with pytest.raises(ValueError, match="fft_length"):
        dis.vibration_frequency(np.zeros(1000), DT, 400, 256)
    with pytest.raises(ValueError, match=r"dt must be finite and > 0, got 0.0"):
        dis.vibration_frequency(np.zeros(1000), 0.0)
    with pytest.raises(ValueError, match="axis"):
        dis.vibration_frequency(np.zeros((1000, 3)), DT, axis=3)
    with pytest.raises(ValueError, match="shape"):
        dis.external_acceleration(np.zeros(10), 4)
    with pytest.raises(ValueError, match="mode"):
        dis.external_acceleration(np.zeros((10, 3)), 4, mode="block")
    with pytest.raises(ValueError, match="non-finite"):
        dis.magnetic_perturbation_measure(np.full((10, 3), np.nan), 4, ref_norm=1.0)
