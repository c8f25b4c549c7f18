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
- The low-pass is causal (``scipy.signal.lfilter``), cut-off ``cutoff_hz`` (default 1 Hz: the
  perturbations in the paper's Fig. 7 vary over seconds).
- The result is scaled so that its largest magnitude equals ``amplitude`` (the paper's test data
  span 0-5 "nu", normalised units of a unit earth field).
"""

from __future__ import annotations

import numpy as np
from scipy import signal

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
            m[sl] = amp[seg] * signal.square(ph)
        elif name == "sawtooth":
            m[sl] = amp[seg] * signal.sawtooth(ph)
        elif name == "triangle":
            m[sl] = amp[seg] * signal.sawtooth(ph, width=0.5)
        else:
            m[sl] = amp[seg] * np.sin(ph)
    return m


def _eq34(m: np.ndarray, dt: float, cutoff_hz: float | None) -> np.ndarray:
    ma = signal.hilbert(m)                        # analytic signal m_r + j m_i
    mp = ma.imag + np.abs(ma)[::-1]               # eq. 34: imaginary part + time-reversed magnitude
    mp = signal.detrend(mp, type="linear")        # step 3: remove the linear trend
    if cutoff_hz is not None:
        b, a = signal.butter(1, cutoff_hz, btype="low", fs=1.0 / dt)
        mp = signal.lfilter(b, a, mp)             # first-order Butterworth low-pass
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
