"""The signal-processing steps of the magnetic-perturbation generator give scipy.signal's bits exactly.

objectives.attitude.data.magnetic reproduces square, sawtooth, hilbert, detrend(linear), butter(1) and
lfilter so that a bench does not import scipy.signal; the pinned digests of the bench6dof recordings rely on
the outputs being the same bits, so every comparison here is np.array_equal, over random lengths (odd and
even), sample times, cut-offs (up to just below Nyquist) and signal scales.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy import signal

from objectives.attitude.data import magnetic as mg


def _scipy_eq34(m, dt, cutoff_hz):
    """Step 2 and 3 of the generator as written with scipy.signal before."""
    ma = signal.hilbert(m)
    mp = signal.detrend(ma.imag + np.abs(ma)[::-1], type="linear")
    if cutoff_hz is not None:
        b, a = signal.butter(1, cutoff_hz, btype="low", fs=1.0 / dt)
        mp = signal.lfilter(b, a, mp)
    return mp


def _settings(seed, count):
    rng = np.random.default_rng(seed)
    for _ in range(count):
        n = int(rng.integers(16, 3000))
        dt = float(10 ** rng.uniform(-3.5, -0.5))
        yield rng, n, dt


@pytest.mark.parametrize("seed", range(4))
def test_waveforms_equal_scipy(seed):
    for rng, n, dt in _settings(seed, 40):
        ph = 2 * np.pi * rng.uniform(0.01, 20.0) * np.arange(n) * dt + rng.uniform(0, 2 * np.pi)
        assert np.array_equal(mg._square(ph), signal.square(ph))
        assert np.array_equal(mg._sawtooth(ph, 1.0), signal.sawtooth(ph))
        assert np.array_equal(mg._sawtooth(ph, 0.5), signal.sawtooth(ph, width=0.5))


@pytest.mark.parametrize("seed", range(4))
def test_hilbert_detrend_butter_lfilter_equal_scipy(seed):
    for rng, n, dt in _settings(100 + seed, 40):
        x = rng.standard_normal(n) * 10 ** rng.uniform(-3, 3) + rng.normal() * np.arange(n)
        assert np.array_equal(mg._analytic(x), signal.hilbert(x))
        assert np.array_equal(mg._detrend_linear(x), signal.detrend(x, type="linear"))
        fs = 1.0 / dt
        for cutoff in (float(rng.uniform(1e-4, 0.9999) * fs / 2), fs / 4, int(max(1, fs // 7))):
            b, a = mg._butter1_lowpass(cutoff, fs)
            b_ref, a_ref = signal.butter(1, cutoff, btype="low", fs=fs)
            assert np.array_equal(b, b_ref) and np.array_equal(a, a_ref), (cutoff, fs)
            assert np.array_equal(mg._lowpass(b, a, x), signal.lfilter(b_ref, a_ref, x)), (cutoff, fs)


@pytest.mark.parametrize("seed", range(3))
def test_generator_equals_the_scipy_version(seed):
    for rng, n, dt in _settings(200 + seed, 15):
        lo = float(rng.uniform(0.01, 3.0))
        freq = (lo, lo * float(rng.uniform(1.0, 10.0)))
        cutoff = None if rng.random() < 0.25 else float(rng.uniform(1e-4, 0.9999) * 0.5 / dt)
        m = mg.base_waveform(n, dt, np.random.default_rng(n), freq)
        assert np.array_equal(mg._eq34(m, dt, cutoff), _scipy_eq34(m, dt, cutoff)), (n, dt, cutoff)


def test_module_does_not_import_scipy_signal():
    import subprocess
    import sys

    code = "import sys, objectives.attitude.data.synthetic; print('scipy.signal' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.split() == ["False"]
