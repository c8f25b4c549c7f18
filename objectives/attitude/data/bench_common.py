"""Motion pieces shared by the synthetic benches: phase schedule, envelopes, random profiles.

Every random number comes from the :class:`numpy.random.Generator` passed in; the benches
(:mod:`objectives.attitude.data.bench6dof`, :mod:`objectives.attitude.data.tilt1d`) give each
component its own spawned stream.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["PHASES"]

# ----------------------------------------------------------------------------------------------
# shared pieces of the benches
# ----------------------------------------------------------------------------------------------
#: Phase types of the benches: (name, vibration, external acceleration, magnetic perturbation, moving).
PHASES = (
    ("static", False, False, False, False),
    ("calm", False, False, False, True),
    ("vibrating", True, False, False, True),
    ("accelerating", False, True, False, True),
    ("magnetic", False, False, True, True),
    ("vibrating+accelerating", True, True, False, True),
    ("disturbed", True, True, True, True),
)


def _schedule(n: int, dt: float, rng: np.random.Generator, phase_s: tuple[float, float],
              types: tuple[int, ...]) -> tuple[np.ndarray, list[tuple[int, int, int]]]:
    """Phase code per sample (index into PHASES) and the list of (start, stop, code).

    Phases have random lengths in ``phase_s`` and cycle through a fresh random permutation of
    ``types``, so every type appears once per cycle.
    """
    lo, hi = phase_s
    if not (0 < lo <= hi):
        raise ValueError(f"phase_s must be (low, high) seconds with 0 < low <= high, got {phase_s!r}")
    codes = np.empty(n, dtype=np.int64)
    spans = []
    start = 0
    while start < n:
        for code in rng.permutation(np.asarray(types)):
            stop = min(n, start + max(1, int(round(rng.uniform(lo, hi) / dt))))
            codes[start:stop] = code
            spans.append((start, stop, int(code)))
            start = stop
            if start >= n:
                break
    return codes, spans


def _smooth(x: np.ndarray, width: int) -> np.ndarray:
    """Two passes of a centred moving average of ``width`` samples (a triangular kernel): ramps
    between phases instead of steps. Ends are padded with the edge values."""
    if width < 2:
        return x.astype(float)
    y = x.astype(float)
    for _ in range(2):
        half = width // 2
        p = np.pad(y, (half + 1, width - half), mode="edge")
        c = np.cumsum(p)
        y = (c[width:width + len(y)] - c[:len(y)]) / width
    return y


def _knots(n: int, dt: float, rng: np.random.Generator, every_s: float, lo: float, hi: float,
           size: int = 1) -> np.ndarray:
    """Piecewise-linear random profile: uniform values in [lo, hi] at knots ``every_s`` apart; (n, size)."""
    t = np.arange(n) * dt
    tk = np.arange(0.0, t[-1] + 2 * every_s, every_s)
    vals = rng.uniform(lo, hi, (len(tk), size))
    return np.stack([np.interp(t, tk, vals[:, j]) for j in range(size)], axis=1)


def _slow_angles(n: int, dt: float, rng: np.random.Generator, amp: np.ndarray,
                 speed: np.ndarray, f_range: tuple[float, float] = (0.02, 0.4)) -> np.ndarray:
    """Slow large rotations: per axis a sum of three sines with random frequency and phase, run on a
    warped time ``tau = cumsum(speed) dt`` (speed 0 freezes the attitude: static phases); (n, len(amp))."""
    tau = np.cumsum(speed) * dt
    k = len(amp)
    f = rng.uniform(f_range[0], f_range[1], (3, k))
    a = rng.uniform(0.3, 1.0, (3, k))
    a = a / a.sum(axis=0) * np.asarray(amp)
    p = rng.uniform(0, 2 * np.pi, (3, k))
    return sum(a[j] * np.sin(2 * np.pi * f[j] * tau[:, None] + p[j]) for j in range(3))


def _oscillation(n: int, dt: float, rng: np.random.Generator, f_range: tuple[float, float],
                 amp_range: tuple[float, float], rate_max: float, axes: int) -> tuple[np.ndarray, np.ndarray]:
    """Sinusoidal oscillation with randomly varying frequency and amplitude (the revolute joints'
    references of the FAEKF bench). One common frequency ``f(t)`` (so the dominant frequency is
    defined), per-axis amplitudes and phases; amplitude limited so that ``2 pi f A <= rate_max``.

    Returns angles (n, axes) rad and f (n,) Hz.
    """
    lo, hi = f_range
    if not (0 < lo <= hi < 0.5 / dt):
        raise ValueError(f"vibration frequency range must satisfy 0 < low <= high < Nyquist, got {f_range!r}")
    f = _knots(n, dt, rng, 1.5, lo, hi)[:, 0]
    amp = _knots(n, dt, rng, 2.0, amp_range[0], amp_range[1], axes)
    amp = np.minimum(amp, rate_max / (2 * np.pi * f[:, None]))
    phase = 2 * np.pi * np.cumsum(f) * dt
    p0 = rng.uniform(0, 2 * np.pi, axes)
    return amp * np.sin(phase[:, None] + p0), f


def _translation_acc(n: int, dt: float, rng: np.random.Generator, amax: float, axes: int,
                     f_range: tuple[float, float] = (0.3, 3.0)) -> np.ndarray:
    """External acceleration of the prismatic joints, (n, axes) m/s^2, each axis within ``+-amax``:
    ``A_i(t) (0.6 sin(2 pi f1 t + p1) + 0.4 sin(2 pi f2 t + p2))`` with ``A_i`` a random profile in
    ``[0.3, 1] amax``."""
    t = np.arange(n) * dt
    f = rng.uniform(f_range[0], f_range[1], (2, axes))
    p = rng.uniform(0, 2 * np.pi, (2, axes))
    amp = _knots(n, dt, rng, 2.0, 0.3 * amax, amax, axes)
    w1 = np.sin(2 * np.pi * f[0] * t[:, None] + p[0])
    w2 = np.sin(2 * np.pi * f[1] * t[:, None] + p[1])
    return amp * (0.6 * w1 + 0.4 * w2)


def _fade(m: int, ramp: int) -> np.ndarray:
    """Raised-cosine fade in and out over ``ramp`` samples, (m,)."""
    w = np.ones(m)
    r = min(ramp, m // 2)
    if r > 0:
        edge = 0.5 - 0.5 * np.cos(np.pi * np.arange(r) / r)
        w[:r] = edge
        w[m - r:] = edge[::-1]
    return w


_SENSOR_KEYS = (
    "gyr_noise", "acc_noise", "mag_noise", "gyr_bias", "gyr_bias_walk", "g", "acc_bias", "mag_bias",
    "gyr_scale", "gyr_misalignment", "acc_scale", "acc_misalignment", "mag_field",
)


def _check_overrides(where: str, overrides: dict, allowed: tuple[str, ...]) -> None:
    bad = sorted(set(overrides) - set(allowed))
    if bad:
        raise ValueError(f"{where}: unknown keyword(s) {bad}; allowed sensor keywords: {', '.join(allowed)}")


def _check_duration(duration_s: float, rate_hz: float) -> tuple[int, float]:
    if not (np.isfinite(duration_s) and duration_s > 0):
        raise ValueError(f"duration_s must be a positive number of seconds, got {duration_s!r}")
    if not (np.isfinite(rate_hz) and rate_hz > 0):
        raise ValueError(f"rate_hz must be a positive number, got {rate_hz!r}")
    from tuner.sizes import check_samples

    n = check_samples("duration_s", round(duration_s * rate_hz), "the recording (duration_s x rate_hz)")
    if n < 16:
        raise ValueError(f"duration_s * rate_hz gives {n} samples; need at least 16")
    return n, 1.0 / rate_hz




@dataclass(frozen=True)
class PhaseEnvelopes:
    """Per-sample weights of the disturbances of a phase schedule, ramped between phases.

    Attributes
    ----------
    ramp : int
        Transition length, samples (0.5 s, at least 2).
    vibration, external_acc, speed : ndarray (n,)
        Weights in [0, 1] of the oscillation, of the external acceleration and of the slow rotation
        (0 freezes the attitude: static phases); the first two are zero where switched off.
    """

    ramp: int
    vibration: np.ndarray
    external_acc: np.ndarray
    speed: np.ndarray


def _phase_envelopes(codes: np.ndarray, dt: float, vibration: bool, external_acc: bool) -> PhaseEnvelopes:
    """Envelopes of the phase codes ``codes`` (n,) (indices into :data:`PHASES`), ramped over 0.5 s."""
    table = np.array([p[1:] for p in PHASES], dtype=float)
    ramp = max(2, int(round(0.5 / dt)))
    return PhaseEnvelopes(
        ramp=ramp,
        vibration=_smooth(table[codes, 0], ramp) * vibration,
        external_acc=_smooth(table[codes, 1], ramp) * external_acc,
        speed=_smooth(table[codes, 3], ramp),
    )


def _sensor_model(defaults: dict, noise: bool, rng: np.random.Generator, overrides: dict) -> dict:
    """Keywords of :func:`~objectives.attitude.data.imu_model.simulate_imu` for a bench.

    With ``noise`` the bench's ``defaults`` (without ``gyr_bias_max``) and an initial gyro bias drawn
    uniformly in ``+-gyr_bias_max`` per axis from ``rng``; without it no noise at all. ``overrides``
    win over both.
    """
    sensor = {}
    if noise:
        sensor = {k: v for k, v in defaults.items() if k != "gyr_bias_max"}
        sensor["gyr_bias"] = rng.uniform(-1, 1, 3) * defaults["gyr_bias_max"]
    sensor.update(overrides)
    return sensor
