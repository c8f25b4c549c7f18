"""Artificial magnetic perturbations: the generator of the FAEKF paper (Odry et al. 2020), eq. 34.

The paper ("Magnetic Perturbations", section 5.1) builds a perturbation in three steps:

1. a perfect artificial signal ``m`` of length ``L_m``: a mixture of square, saw-tooth, triangle and
   two sinusoidal signals whose sequence and parameters (amplitude, frequency) are random;
2. the analytic signal ``m_a = m_r + j m_i`` (Hilbert transform) and the perturbation
   ``m_p,k = m_i,k + |m_a,l|``, ``l = L_m + 1 - k`` (magnitude reversed in time), eq. 34;
3. removal of the linear trend and a first-order Butterworth IIR low-pass.

Where the paper leaves choices open (figures only), this module documents its own:

- "mixture ... sequence": the five waveforms are placed one after the other in a random order,
  with random segment lengths (each at least 10 % of ``L_m``), random amplitudes in
  ``[0.2, 1]`` and random frequencies in ``freq_range_hz``.
- The low-pass is causal (a direct-form filter run forwards), cut-off ``cutoff_hz`` (default 1 Hz: the
  perturbations in the paper's Fig. 7 vary over seconds).
- The result is scaled so that its largest magnitude equals ``amplitude`` (the paper's test data
  span 0-5 "nu", normalised units of a unit earth field).

The signal-processing steps are this module's own code, written to give the bits of ``scipy.signal``
(1.17: ``square``, ``sawtooth``, ``hilbert``, ``detrend``, ``butter``, ``lfilter``) operation for
operation; ``tests/attitude/test_magnetic_signal.py`` checks them against it with exact equality.
``scipy.signal`` costs about 0.6 s of import (it pulls ``scipy.stats``) in every process that builds a
bench; the FFT and the least-squares solve still come from ``scipy.fft`` and ``scipy.linalg``.
"""

from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["magnetic_perturbation", "base_waveform"]

_WAVES = ("square", "sawtooth", "triangle", "sine", "sine")


def base_waveform(n: int, dt: float, rng: np.random.Generator,
                  freq_range_hz: tuple[float, float] = (0.1, 2.0)) -> np.ndarray:
    """Step 1 of the generator: square, saw-tooth, triangle and two sines in random order, (n,)."""
    order = rng.permutation(len(_WAVES))
    # random segment lengths, each >= 10 % of n
    w = 0.1 + 0.5 * rng.random(len(_WAVES))
    bounds = np.concatenate([[0], np.round(np.cumsum(w / w.sum()) * n).astype(int)])
    bounds[-1] = n
    amp = rng.uniform(0.2, 1.0, len(_WAVES))
    freq = rng.uniform(freq_range_hz[0], freq_range_hz[1], len(_WAVES))
    phase0 = rng.uniform(0.0, 2 * np.pi, len(_WAVES))
    t = np.arange(n) * dt
    m = np.empty(n)
    for seg, kind in enumerate(order):
        sl = slice(bounds[seg], bounds[seg + 1])
        ph = 2 * np.pi * freq[seg] * t[sl] + phase0[seg]
        name = _WAVES[kind]
        if name == "square":
            m[sl] = amp[seg] * _square(ph)
        elif name == "sawtooth":
            m[sl] = amp[seg] * _sawtooth(ph, 1.0)
        elif name == "triangle":
            m[sl] = amp[seg] * _sawtooth(ph, 0.5)
        else:
            m[sl] = amp[seg] * np.sin(ph)
    return m


def _square(ph: np.ndarray) -> np.ndarray:
    """Square wave of period 2 pi, +1 on ``[0, pi)`` and -1 on ``[pi, 2 pi)`` (``scipy.signal.square``, duty 0.5).

    ``tmod = ph mod 2 pi``; +1 where ``tmod < duty * 2 * pi``, else -1.
    """
    tmod = np.mod(ph, 2 * np.pi)
    return np.where(tmod < 0.5 * 2 * np.pi, 1.0, -1.0)


def _sawtooth(ph: np.ndarray, width: float) -> np.ndarray:
    """Saw-tooth of period 2 pi rising from -1 to 1 over ``[0, 2 pi width)`` (``scipy.signal.sawtooth``).

    With ``tmod = ph mod 2 pi`` and ``w = width`` (1: saw-tooth, 0.5: triangle)::

        y = tmod / (pi w) - 1                   for tmod <  2 pi w   (rising ramp)
        y = (pi (w + 1) - tmod) / (pi (1 - w))  for tmod >= 2 pi w   (falling ramp)

    in scipy's order of operations.
    """
    tmod = np.mod(ph, 2 * np.pi)
    y = np.empty_like(tmod)
    rise = tmod < width * 2 * np.pi
    y[rise] = tmod[rise] / (np.pi * width) - 1
    fall = ~rise
    y[fall] = (np.pi * (width + 1) - tmod[fall]) / (np.pi * (1 - width))
    return y


def _analytic(x: np.ndarray) -> np.ndarray:
    """Analytic signal ``x + j H{x}`` by the FFT (``scipy.signal.hilbert``; Marple 1999).

    ``X = FFT(x)``; ``X[k]`` is doubled for ``0 < k < N/2`` and zeroed for ``k > N/2`` (``X[0]`` and, for
    even N, ``X[N/2]`` are kept); the result is ``IFFT(X)``.
    """
    from scipy import fft  # deferred: a tilt1d-only or cached run never needs it (~0.15 s of import)

    n = x.shape[0]
    xf = fft.fft(x, n)
    if n % 2 == 0:
        xf[1:n // 2] *= 2.0
        xf[n // 2 + 1:n] = 0.0
    else:
        xf[1:(n + 1) // 2] *= 2.0
        xf[(n + 1) // 2:n] = 0.0
    return fft.ifft(xf)


def _detrend_linear(x: np.ndarray) -> np.ndarray:
    """``x`` minus its least-squares straight line (``scipy.signal.detrend(x, type="linear")``).

    The line is ``A c`` with ``A = [k / N, 1]``, ``k = 1..N``, and ``c`` the least-squares solution of
    ``A c = x`` (LAPACK ``gelsd`` through ``scipy.linalg.lstsq``), on an (N, 1) right-hand side as scipy
    has it.
    """
    from scipy import linalg  # deferred: a tilt1d-only or cached run never needs it (~0.15 s of import)

    n = x.shape[0]
    data = x.reshape(n, 1).copy()
    a = np.ones((n, 2), "d")
    a[:, 0] = np.arange(1, n + 1, dtype="d") / n
    coef = linalg.lstsq(a, data)[0]
    return (data - a @ coef).reshape(n)


def _butter1_lowpass(cutoff_hz: float, fs_hz: float) -> tuple[np.ndarray, np.ndarray]:
    """``b, a`` of the first-order Butterworth low-pass (``scipy.signal.butter(1, cutoff_hz, fs=fs_hz)``).

    scipy's route, in its operations: the analogue prototype's pole ``p = -1`` (``buttap``), the
    pre-warped cut-off ``w = 2 f tan(pi Wn / f)`` with ``f = 2`` and ``Wn = cutoff / (fs / 2)``, the pole
    scaled to ``w p`` with gain ``w`` (``lp2lp_zpk``), the bilinear transform ``z = (2f + s) / (2f - s)``
    with the zero at infinity moved to -1 and gain ``w Re(1 / (2f - w p))`` (``bilinear_zpk``), and the
    polynomials of zeros and poles (``zpk2tf``): ``b = k [1, 1]``, ``a = [1, -p_z]``.
    """
    wn = np.asarray(cutoff_hz, dtype=np.float64) / (float(fs_hz) / 2)
    fs = 2.0
    wo = float(2 * fs * np.tan(np.pi * wn / fs))                  # pre-warped cut-off, rad/s
    p = -np.exp(1j * np.pi * np.arange(0.0, 1.0, 2.0) / 2)       # buttap(1): the pole -1
    z = np.asarray([], dtype=np.float64)
    p = wo * p                                                    # lp2lp_zpk: k = 1.0 * wo**1
    k = 1.0 * wo ** 1
    fs2 = 2.0 * fs                                                # bilinear_zpk
    z_z = np.concatenate((z, -np.ones(1)))
    p_z = (fs2 + p) / (fs2 - p)
    k_z = k * np.real(np.prod(fs2 - z) / np.prod(fs2 - p))
    b = np.asarray(k_z, dtype=np.float64).reshape(1) * _poly(z_z)
    return b, _poly(p_z)


def _poly(roots: np.ndarray) -> np.ndarray:
    """Coefficients of ``prod (x - r)`` by repeated convolution (scipy's ``_polyutils.poly``), real
    when the roots' imaginary parts are symmetric."""
    a = np.ones((1,), dtype=roots.dtype)
    one = np.ones_like(roots[0])
    for r in roots:
        a = np.convolve(a, np.stack((one, -r)), mode="full")
    if np.iscomplexobj(a):
        roots_c = np.asarray(roots, dtype=np.complex128)
        if np.all(np.sort(np.imag(roots_c)) == np.sort(np.imag(np.conj(roots_c)))):
            a = np.real(a).copy()
    return a


@njit(cache=True)
def _lfilter1(b0, b1, a1, x, y):
    """First-order IIR ``y[k] = b0 x[k] + b1 x[k-1] - a1 y[k-1]``, direct form II transposed from rest
    (``scipy.signal.lfilter`` with ``a[0] = 1``)::

        y[k] = z + b0 x[k]
        z    = x[k] b1 - y[k] a1
    """
    z = 0.0
    for k in range(x.shape[0]):
        y[k] = z + b0 * x[k]
        z = x[k] * b1 - y[k] * a1


def _lowpass(b: np.ndarray, a: np.ndarray, x: np.ndarray) -> np.ndarray:
    """``scipy.signal.lfilter(b, a, x)`` for a first-order ``b, a`` (coefficients divided by ``a[0]``)."""
    b = b / a[0]
    a = a / a[0]
    y = np.empty_like(x)
    _lfilter1(b[0], b[1], a[1], np.ascontiguousarray(x), y)
    return y


def _eq34(m: np.ndarray, dt: float, cutoff_hz: float | None) -> np.ndarray:
    ma = _analytic(m)                             # analytic signal m_r + j m_i
    mp = ma.imag + np.abs(ma)[::-1]               # eq. 34: imaginary part + time-reversed magnitude
    mp = _detrend_linear(mp)                      # step 3: remove the linear trend
    if cutoff_hz is not None:
        b, a = _butter1_lowpass(cutoff_hz, 1.0 / dt)
        mp = _lowpass(b, a, mp)                   # first-order Butterworth low-pass
    return mp


def magnetic_perturbation(
    n: int,
    dt: float,
    rng: np.random.Generator,
    *,
    axes: int = 3,
    amplitude: float = 1.0,
    cutoff_hz: float | None = 1.0,
    freq_range_hz: tuple[float, float] = (0.1, 2.0),
) -> np.ndarray:
    """Random magnetic perturbation by the FAEKF paper's generator (eq. 34).

    Parameters
    ----------
    n : int
        Number of samples ``L_m`` (>= 16).
    dt : float
        Sample time, s.
    rng : numpy.random.Generator
        Source of all randomness.
    axes : {1, 3}
        1: one signal, shape (n,); 3: three independent components, shape (n, 3).
    amplitude : float
        Largest magnitude of the result (norm of the vector for ``axes=3``), in the field's unit
        (1 = one earth field when the field is normalised). 0 gives zeros.
    cutoff_hz : float or None
        Cut-off of the first-order Butterworth low-pass, Hz; None skips the filter (step 3 then
        only detrends; used to test the filter).
    freq_range_hz : (float, float)
        Range of the base waveforms' frequencies, Hz.

    Returns
    -------
    ndarray (n,) or (n, 3)
    """
    n = int(n)
    if n < 16:
        raise ValueError(f"magnetic_perturbation needs n >= 16 samples, got {n}")
    if not (np.isfinite(dt) and dt > 0):
        raise ValueError(f"dt must be a positive number of seconds, got {dt!r}")
    if axes not in (1, 3):
        raise ValueError(f"axes must be 1 or 3, got {axes!r}")
    if not (np.isfinite(amplitude) and amplitude >= 0):
        raise ValueError(f"amplitude must be a finite number >= 0, got {amplitude!r}")
    if cutoff_hz is not None and not (0 < cutoff_hz < 0.5 / dt):
        raise ValueError(f"cutoff_hz must be in (0, {0.5 / dt:g}) Hz (below Nyquist), got {cutoff_hz!r}")
    lo, hi = freq_range_hz
    if not (0 < lo <= hi):
        raise ValueError(f"freq_range_hz must be (low, high) with 0 < low <= high, got {freq_range_hz!r}")
    if not isinstance(rng, np.random.Generator):
        raise ValueError("rng must be a numpy.random.Generator (numpy.random.default_rng(seed))")
    out = np.stack([_eq34(base_waveform(n, dt, rng, freq_range_hz), dt, cutoff_hz)
                    for _ in range(axes)], axis=1)
    peak = np.max(np.linalg.norm(out, axis=1))
    if peak > 0:
        out *= amplitude / peak
    return out[:, 0] if axes == 1 else out
