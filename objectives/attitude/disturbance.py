"""Disturbance measures for adaptive filters: vibration, external acceleration, magnetic perturbation.

Sources: Odry 2020 PhD thesis, section 3.1.4 (eqs. 3.19-3.22), and Odry et al. 2020, Sensors 20, 803
(the FAEKF paper), section 4.1-4.2 (eqs. 23-27). Any filter can use them; the AKF1D and the FAEKF do.

Packets and timing
------------------
The papers collect *packets* of ``L = window`` consecutive samples and compute each measure once per
packet ("L = 400 has been chosen to synchronize the measures", thesis 3.1.4.2). Packet ``p`` covers
samples ``[p L, (p + 1) L)``. With ``causal=True`` (the default, what a real-time filter sees) the
measure of packet ``p`` becomes available when the packet is complete and is **held** over the
samples of packet ``p + 1``; the samples of the first packet get 0 ("no disturbance measured yet", the
state the thesis's filter starts in), and a trailing partial packet holds the last complete packet's
value. With ``causal=False`` each packet's own samples get its measure (no delay; for analysis and
plots), and a trailing partial packet holds the last complete packet's value.

:func:`external_acceleration` and :func:`magnetic_perturbation_measure` also offer ``mode="sliding"``:
the mean over the trailing ``L`` samples ``[k - L + 1, k]`` at every sample (running sums, O(N)),
over the available ``k + 1`` samples while ``k < L - 1``.

Cost
----
Everything is O(N): the FFTs of all packets in one vectorised :func:`numpy.fft.rfft` call (numba has
no FFT), the dominant-bin search and the windowed means in numba kernels.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numba import njit

__all__ = ["vibration_frequency", "packet_spectrum", "external_acceleration", "magnetic_perturbation_measure",
           "G_STANDARD", "CONTEXT_KEYS"]

#: the gravity magnitude used by default, m/s^2 (the value the synthetic benches use)
G_STANDARD = 9.81
#: filter values on which precomputed fuzzy inputs (these disturbance measures) depend: the filter
#: objective prepares them once per split and these values (objectives.attitude.prepared), serial and batch
CONTEXT_KEYS = ("window", "fft_length", "f_thr", "omega_thr", "use_mag", "acc_window", "mag_window")


def _int_at_least(name: str, value: Any, low: int) -> int:
    if isinstance(value, bool) or int(value) != value or int(value) < low:
        raise ValueError(f"{name} must be an integer >= {low}, got {value!r}")
    return int(value)


def _positive(name: str, value: Any) -> float:
    v = float(value)
    if not (math.isfinite(v) and v > 0):
        raise ValueError(f"{name} must be finite and > 0, got {value!r}")
    return v


def _hold(per_packet: np.ndarray, n: int, window: int, causal: bool) -> np.ndarray:
    """Spread per-packet values over samples (see the module docstring)."""
    out = np.zeros(n)
    n_p = per_packet.shape[0]
    if n_p == 0:
        return out
    if causal:
        vals = per_packet[: n_p - 1] if n_p > 1 else per_packet[:0]
        out[window: window * n_p] = np.repeat(vals, window)
        out[window * n_p:] = per_packet[-1]
    else:
        out[: window * n_p] = np.repeat(per_packet, window)
        out[window * n_p:] = per_packet[-1]
    return out


def packet_spectrum(x: np.ndarray, window: int, fft_length: int, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """Amplitude spectra of the complete packets of ``x`` (eqs. 3.19-3.20 / FAEKF eqs. 23-24).

    Parameters
    ----------
    x : (N,) or (N, m) signal (e.g. gyro rate, rad/s); columns are transformed separately.
    window, fft_length : packet length L and transform length L_FFT (zero padding, ``L_FFT >= L``).
    dt : sampling period, s.

    Returns
    -------
    f : (L_FFT // 2 + 1,) bin frequencies ``f_i = f_s i / L_FFT``, Hz.
    amp : (n_packets, L_FFT // 2 + 1) or (n_packets, m, L_FFT // 2 + 1) amplitudes ``(2 / L) |W_i|``
        (a sinusoid of amplitude A centred on a bin gives A).
    """
    x = np.asarray(x, dtype=float)
    n_p = x.shape[0] // window
    pk = x[: n_p * window].reshape((n_p, window) + x.shape[1:])
    if x.ndim == 2:
        pk = pk.transpose(0, 2, 1)
    amp = np.abs(np.fft.rfft(pk, n=fft_length, axis=-1)) * (2.0 / window)
    return np.fft.rfftfreq(fft_length, dt), amp


@njit(cache=True)
def _dominant(amp, n_bins, omega_thr, df, out):
    """Eq. 3.21 / FAEKF eq. 25 for every packet: amp (n_p, m, n_f) -> out (n_p,) Hz."""
    for p in range(amp.shape[0]):
        best = -1.0
        best_i = 0
        for c in range(amp.shape[1]):
            for i in range(n_bins):
                a = amp[p, c, i]
                if a > best:
                    best = a
                    best_i = i
        out[p] = 0.0 if best < omega_thr else best_i * df


def vibration_frequency(gyr: np.ndarray, dt: float, window: int = 400, fft_length: int = 512,
                        omega_thr: float = 0.26, axis: int | None = None, f_thr: float = 10.0,
                        causal: bool = True) -> np.ndarray:
    """Oscillation frequency estimate ``f_hat`` for every sample (thesis eqs. 3.19-3.21, FAEKF eqs. 23-25).

    For each packet of ``window`` gyro samples: the DFT of length ``fft_length`` (zero padded),
    amplitudes ``(2 / L) |W_i|`` at ``f_i = i / (L_FFT dt)``; among the bins with ``f_i <= f_thr`` the
    one of highest amplitude; ``f_hat = 0`` if that amplitude is below ``omega_thr``, else its
    frequency. Held between packet updates as described in the module docstring (causal: one packet
    of delay, 0 over the first packet). The signal is not detrended (as in eq. 3.19): a constant rate
    puts its energy in bin 0, i.e. ``f_hat = 0``.

    Parameters
    ----------
    gyr : (N,) or (N, 3) angular rate, rad/s.
    dt : sampling period, s.
    window : packet length L (thesis and FAEKF paper: 400).
    fft_length : transform length L_FFT >= L (papers: 512; resolution ``1 / (L_FFT dt)``).
    omega_thr : amplitude threshold ``|Omega|_thr``, rad/s (FAEKF: 0.26; thesis: 10 deg/s = 0.1745).
    axis : column of ``gyr`` to analyse; None uses every column and the highest-amplitude bin over
        all of them (a rotation about any axis counts; no frequency doubling as with ``|omega|``).
    f_thr : highest frequency considered, Hz (thesis: 8 Hz for the WMP; FAEKF config: 10 Hz).
    causal : hold each packet's estimate over the next packet (True) or over its own samples.

    Returns
    -------
    (N,) frequency, Hz; a multiple of the bin width ``1 / (L_FFT dt)``.
    """
    g = np.asarray(gyr, dtype=float)
    if g.ndim not in (1, 2) or g.shape[0] == 0:
        raise ValueError(f"gyr must have shape (N,) or (N, m), got {g.shape}")
    dt = _positive("dt", dt)
    window = _int_at_least("window", window, 2)
    fft_length = _int_at_least("fft_length", fft_length, 2)
    if fft_length < window:
        raise ValueError(f"fft_length ({fft_length}) must be >= window ({window})")
    omega_thr = float(omega_thr)
    if not (math.isfinite(omega_thr) and omega_thr >= 0):
        raise ValueError(f"omega_thr must be finite and >= 0, got {omega_thr!r}")
    f_thr = _positive("f_thr", f_thr)
    if axis is not None:
        if g.ndim != 2 or not (0 <= int(axis) < g.shape[1]):
            raise ValueError(f"axis={axis!r} needs gyr of shape (N, m) with 0 <= axis < m, got {g.shape}")
        g = g[:, int(axis)]
    if not np.all(np.isfinite(g)):
        raise ValueError("gyr has non-finite values")
    f, amp = packet_spectrum(g, window, fft_length, dt)
    if amp.ndim == 2:
        amp = amp[:, None, :]
    df = f[1] - f[0]
    n_bins = int(np.searchsorted(f, f_thr * (1 + 1e-12), side="right"))
    per_packet = np.empty(amp.shape[0])
    _dominant(np.ascontiguousarray(amp), n_bins, omega_thr, df, per_packet)
    return _hold(per_packet, g.shape[0], window, bool(causal))


@njit(cache=True)
def _windowed_mean(x, window, packet, causal, out):
    """Packet or sliding mean of x (N,) into out (N,) (see the module docstring)."""
    n = x.shape[0]
    if packet:
        n_p = n // window
        for k in range(n):
            out[k] = 0.0
        last = 0.0
        for p in range(n_p):
            s = 0.0
            for k in range(p * window, (p + 1) * window):
                s += x[k]
            last = s / window
            start = (p + 1) * window if causal else p * window
            for k in range(start, min(start + window, n)):
                out[k] = last
        if not causal and n_p > 0:
            for k in range(n_p * window, n):
                out[k] = last
    else:
        s = 0.0
        for k in range(n):
            s += x[k]
            if k >= window:
                s -= x[k - window]
            m = s / min(k + 1, window)
            out[k] = m if m > 0.0 else 0.0


@njit(cache=True)
def _abs_norm_dev(v, ref, out):
    """out[k] = | |v_k| - ref | / ref. Three columns are summed written out (the same additions in the same
    order): numba does not unroll the inner loop of unknown length, and the written-out sum is 4x faster."""
    if v.shape[1] == 3:
        for k in range(v.shape[0]):
            x = v[k, 0]
            y = v[k, 1]
            z = v[k, 2]
            out[k] = abs(math.sqrt(x * x + y * y + z * z) - ref) / ref
        return
    for k in range(v.shape[0]):
        s = 0.0
        for j in range(v.shape[1]):
            s += v[k, j] * v[k, j]
        out[k] = abs(math.sqrt(s) - ref) / ref


def _measure(v: np.ndarray, name: str, window: int, ref: float, mode: str, causal: bool) -> np.ndarray:
    v = np.ascontiguousarray(np.asarray(v, dtype=float))
    if v.ndim != 2 or v.shape[0] == 0:
        raise ValueError(f"{name} must have shape (N, 3), got {v.shape}")
    if not np.all(np.isfinite(v)):
        raise ValueError(f"{name} has non-finite values")
    window = _int_at_least("window", window, 1)
    if mode not in ("packet", "sliding"):
        raise ValueError(f"mode must be 'packet' or 'sliding', got {mode!r}")
    dev = np.empty(v.shape[0])
    _abs_norm_dev(v, ref, dev)
    out = np.empty(v.shape[0])
    _windowed_mean(dev, window, mode == "packet", bool(causal), out)
    return out


def external_acceleration(acc: np.ndarray, window: int = 400, g: float = G_STANDARD, mode: str = "packet",
                          causal: bool = True) -> np.ndarray:
    """Average external acceleration ``alpha_hat`` in g (thesis eq. 3.22, FAEKF eq. 26).

    ``alpha_hat = (1/L) sum | |A_k| - g | / g`` over packets (or a sliding window) of ``L = window``
    samples; see the module docstring for the timing.

    Parameters
    ----------
    acc : (N, 3) specific force, m/s^2 (any unit if ``g`` is given in it).
    window : L (papers: 400).
    g : gravity magnitude in the unit of ``acc``; the result is in units of ``g``.
    mode : "packet" (the papers) or "sliding".
    causal : packet mode only: hold each packet's mean over the next packet.

    Returns
    -------
    (N,) average external acceleration, g.
    """
    return _measure(acc, "acc", window, _positive("g", g), mode, causal)


def magnetic_perturbation_measure(mag: np.ndarray, window: int = 400, ref_norm: float | None = None,
                                  mode: str = "packet", causal: bool = True) -> np.ndarray:
    """Average magnetic perturbation ``h_hat`` in normalised units (FAEKF eq. 27).

    ``h_hat = (1/L) sum | |m_k| - |m_0| | / |m_0|`` over packets (or a sliding window) of
    ``L = window`` samples.

    Parameters
    ----------
    mag : (N, 3) magnetic field, any unit.
    window : L (FAEKF paper: 400).
    ref_norm : norm of the undisturbed reference field ``|E h|`` in the unit of ``mag``; None uses the
        median of ``|m_k|`` over the recording (robust to perturbations shorter than half of it, but
        not causal: pass the known value for a real-time equivalent).
    mode, causal : as :func:`external_acceleration`.

    Returns
    -------
    (N,) average magnetic perturbation as a fraction of the reference norm.
    """
    m = np.asarray(mag, dtype=float)
    if ref_norm is None:
        if m.ndim != 2 or m.shape[0] == 0 or not np.all(np.isfinite(m)):
            raise ValueError(f"mag must be a finite (N, 3) array, got shape {m.shape}")
        ref = float(np.median(np.linalg.norm(m, axis=1)))
        if not ref > 0:
            raise ValueError("mag: the median field norm is 0; give ref_norm")
    else:
        ref = _positive("ref_norm", ref_norm)
    return _measure(m, "mag", window, ref, mode, causal)
