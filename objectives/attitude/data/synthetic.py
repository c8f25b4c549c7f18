"""Synthetic IMU recordings with exact ground truth: the sensor model and the test benches.

Everything here is plain vectorised NumPy (no per-sample Python) and every random number comes
from a :class:`numpy.random.Generator`; the same seed gives bit-identical recordings.

Contents
--------
- :func:`simulate_imu`: gyroscope, accelerometer and magnetometer readings of a given true
  orientation trajectory, with the sensor models of the FAEKF paper (Odry et al. 2020, Sensors 20,
  803), eqs. 7 and 9.
- :func:`bench6dof`: the 6-DOF test bench of the FAEKF paper, section 5.1.
- :func:`tilt1d`: the 1-D tilt test bench of the thesis (Odry 2020), section 3.1.2.
- :func:`magnetic_perturbation`: the perturbation generator of the FAEKF paper, eq. 34
  (in :mod:`objectives.attitude.data.magnetic`).
- :func:`synthetic`: a cached dispatcher by generator name; :func:`to_csv` exports a recording.

Conventions
-----------
Quaternions are ``(w, x, y, z)`` sensor-to-earth (see :mod:`objectives.attitude.data.recording`).
The gyroscope reading ``gyr[k]`` is the **constant body rate over** ``[t_k, t_k+1]``, so the exact
integration rule is ::

    q[k+1] = q[k] * exp(gyr[k] * dt / 2),   exp(v) = (cos|v|, sin|v| v / |v|)

(right multiplication: the rate is expressed in the sensor frame). With all noise zero, integrating
``gyr`` with this rule reproduces ``quat`` to rounding (up to the sign of the quaternion, which does
not change the rotation). The last sample repeats the rate of the one before it.
"""

from __future__ import annotations

import functools
import hashlib
import json
import math
import os
from dataclasses import replace
from pathlib import Path

import numpy as np

from objectives.attitude.data.magnetic import magnetic_perturbation
from objectives.attitude.data.recording import Recording

__all__ = [
    "simulate_imu", "body_rate", "earth_gravity", "earth_field", "quat_exp", "quat_log",
    "rotate", "DEFAULT_INCLINATION_DEG", "bench6dof", "tilt1d", "magnetic_perturbation", "synthetic",
    "to_csv", "csv_columns", "PHASES", "GENERATORS", "BENCH6DOF_SENSOR", "TILT1D_SENSOR",
]

#: Default magnetic inclination (dip), degrees: Budapest is about 63-64 deg (IGRF 2020).
DEFAULT_INCLINATION_DEG = 63.5


# ----------------------------------------------------------------------------------------------
# vectorised quaternion helpers (NumPy, (N, 4) / (N, 3))
# ----------------------------------------------------------------------------------------------
def _qmul(p: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Row-wise Hamilton product of (..., 4) arrays (broadcasting)."""
    pw, px, py, pz = np.moveaxis(p, -1, 0)
    qw, qx, qy, qz = np.moveaxis(q, -1, 0)
    return np.stack([
        pw * qw - px * qx - py * qy - pz * qz,
        pw * qx + px * qw + py * qz - pz * qy,
        pw * qy - px * qz + py * qw + pz * qx,
        pw * qz + px * qy - py * qx + pz * qw,
    ], axis=-1)


def _qconj(q: np.ndarray) -> np.ndarray:
    out = np.array(q, dtype=float, copy=True)
    out[..., 1:] *= -1.0
    return out


def rotate(q: np.ndarray, v: np.ndarray, inverse: bool = False) -> np.ndarray:
    """Rotate vectors by unit quaternions, row-wise.

    Parameters
    ----------
    q : ndarray (N, 4) or (4,)
        Unit quaternions ``(w, x, y, z)``.
    v : ndarray (N, 3) or (3,)
        Vectors.
    inverse : bool
        False: ``q * v * conj(q)`` (sensor -> earth for a sensor-to-earth ``q``);
        True: ``conj(q) * v * q`` (earth -> sensor).

    Returns
    -------
    ndarray (N, 3)
    """
    q = np.asarray(q, dtype=float)
    v = np.asarray(v, dtype=float)
    w, x, y, z = np.moveaxis(q, -1, 0)
    if inverse:
        x, y, z = -x, -y, -z
    vx, vy, vz = np.moveaxis(v, -1, 0)
    return np.stack([
        (1 - 2 * (y * y + z * z)) * vx + 2 * (x * y - w * z) * vy + 2 * (x * z + w * y) * vz,
        2 * (x * y + w * z) * vx + (1 - 2 * (x * x + z * z)) * vy + 2 * (y * z - w * x) * vz,
        2 * (x * z - w * y) * vx + 2 * (y * z + w * x) * vy + (1 - 2 * (x * x + y * y)) * vz,
    ], axis=-1)


def quat_exp(v: np.ndarray) -> np.ndarray:
    """Quaternion exponential of pure quaternions ``(0, v)``: ``(cos|v|, sin|v| v/|v|)``; (N, 3) -> (N, 4)."""
    v = np.asarray(v, dtype=float)
    n = np.linalg.norm(v, axis=-1)
    safe = np.where(n > 0, n, 1.0)
    # sin(n)/n with its series below 1e-4 (error < 1e-17)
    sinc = np.where(n > 1e-4, np.sin(n) / safe, 1.0 - n * n / 6.0)
    return np.concatenate([np.cos(n)[..., None], sinc[..., None] * v], axis=-1)


def quat_log(q: np.ndarray) -> np.ndarray:
    """Logarithm ``v`` of unit quaternions (``exp(v) = q``, the shorter of ``q``, ``-q``), (N, 4) -> (N, 3).

    ``|v| <= pi/2`` (rotation angle ``2|v| <= pi``).
    """
    q = np.asarray(q, dtype=float)
    q = np.where(q[..., :1] < 0, -q, q)
    w = q[..., 0]
    s = np.linalg.norm(q[..., 1:], axis=-1)
    safe = np.where(s > 0, s, 1.0)
    # atan2(s, w)/s; for s -> 0 (w -> 1) the limit is 1/w
    f = np.where(s > 1e-8, np.arctan2(s, w) / safe, 1.0 / w)
    return f[..., None] * q[..., 1:]


def _make_continuous(q: np.ndarray) -> np.ndarray:
    """Flip signs so that consecutive quaternions have a non-negative dot product."""
    d = np.einsum("ij,ij->i", q[1:], q[:-1])
    flips = np.concatenate([[False], d < 0])
    sign = np.where(np.cumsum(flips) % 2 == 1, -1.0, 1.0)
    return q * sign[:, None]


# ----------------------------------------------------------------------------------------------
# earth references
# ----------------------------------------------------------------------------------------------
def earth_gravity(frame: str, g: float = 9.81) -> np.ndarray:
    """Specific force at rest in the earth frame, m/s^2: ``g`` along *up*.

    NED: ``(0, 0, -g)``; ENU: ``(0, 0, +g)``. (The FAEKF paper writes ``(0, 0, 9.81)`` in its eq. 10
    with the opposite sign convention for the accelerometer; the project's :class:`Recording` reads
    +g along up, as BROAD and most sensors do.)
    """
    _check_frame(frame)
    return np.array([0.0, 0.0, -g if frame == "NED" else g])


def earth_field(frame: str, inclination_deg: float = DEFAULT_INCLINATION_DEG,
                magnitude: float = 1.0) -> np.ndarray:
    """Earth magnetic field vector, pointing to magnetic north (= earth north) and dipping down.

    NED: ``b (cos s, 0, sin s)`` (FAEKF paper, text after eq. 10); ENU: ``b (0, cos s, -sin s)``.
    ``magnitude`` 1 gives the normalised field the paper's figures show (unit "1").
    """
    _check_frame(frame)
    s = math.radians(inclination_deg)
    if frame == "NED":
        return magnitude * np.array([math.cos(s), 0.0, math.sin(s)])
    return magnitude * np.array([0.0, math.cos(s), -math.sin(s)])


def _check_frame(frame: str) -> None:
    if frame not in ("NED", "ENU"):
        raise ValueError(f"frame must be 'NED' or 'ENU', got {frame!r}")


def _vec3(name: str, value, n: int | None = None) -> np.ndarray:
    a = np.asarray(value, dtype=float)
    if a.shape == (3,):
        return a
    if n is not None and a.shape == (n, 3):
        return a
    allowed = "(3,)" if n is None else f"(3,) or ({n}, 3)"
    raise ValueError(f"{name} must have shape {allowed}, got {a.shape}")


def _mat3(name: str, value) -> np.ndarray | None:
    if value is None:
        return None
    a = np.asarray(value, dtype=float)
    if a.shape == (3,):
        return np.diag(a)
    if a.shape != (3, 3):
        raise ValueError(f"{name} must be None, (3,) (diagonal) or (3, 3), got {a.shape}")
    return a


def _nonneg(name: str, value: float) -> float:
    v = float(value)
    if not (np.isfinite(v) and v >= 0):
        raise ValueError(f"{name} must be a finite number >= 0, got {value!r}")
    return v


# ----------------------------------------------------------------------------------------------
# the sensor model
# ----------------------------------------------------------------------------------------------
def body_rate(quat: np.ndarray, dt: float) -> np.ndarray:
    """Exact body rate (sensor frame), rad/s: ``gyr[k] = 2 log(conj(q_k) q_k+1) / dt``.

    Parameters
    ----------
    quat : ndarray (N, 4), N >= 2
    dt : float, s

    Returns
    -------
    ndarray (N, 3)
        ``gyr[k]`` is constant over ``[t_k, t_k+1]``; the last row repeats the one before it.
    """
    dq = _qmul(_qconj(quat[:-1]), quat[1:])
    w = 2.0 * quat_log(dq) / dt
    return np.concatenate([w, w[-1:]], axis=0)


def simulate_imu(
    quat: np.ndarray,
    dt: float,
    *,
    frame: str = "NED",
    rng: np.random.Generator | None = None,
    gyr_noise: float = 0.0,
    acc_noise: float = 0.0,
    mag_noise: float = 0.0,
    gyr_bias=(0.0, 0.0, 0.0),
    gyr_bias_walk: float = 0.0,
    ext_acc: np.ndarray | None = None,
    mag_field=None,
    mag_perturbation: np.ndarray | None = None,
    g: float = 9.81,
    name: str = "synthetic",
    acc_bias=(0.0, 0.0, 0.0),
    mag_bias=(0.0, 0.0, 0.0),
    gyr_scale=None,
    gyr_misalignment=None,
    acc_scale=None,
    acc_misalignment=None,
    motion: np.ndarray | None = None,
    extra: dict | None = None,
    source: str = "",
) -> Recording:
    """IMU readings of a true orientation trajectory (FAEKF paper eqs. 7 and 9).

    Gyroscope (eq. 7)::

        gyr_k  = (I + dS_W) M_W w_k + b_k + mu_k,    b_k = b_k-1 + eta_k,   b_0 = gyr_bias

    Accelerometer and magnetometer (eq. 9, soft/hard iron already compensated, as the paper
    assumes)::

        acc_k = (I + dS_A) M_A R_k^T (ext_acc_k + g up) + acc_bias + nu_k
        mag_k = R_k^T h_k + mag_perturbation_k + mag_bias + eps_k

    with ``R_k`` the sensor-to-earth rotation of ``quat[k]``. The exact body rate ``w_k`` follows
    the integration rule of the module docstring: ``q[k+1] = q[k] * exp(w_k dt / 2)``.

    Parameters
    ----------
    quat : ndarray (N, 4)
        True sensor-to-earth orientation ``(w, x, y, z)`` in ``frame``; normalised here and made
        sign-continuous (``q`` and ``-q`` are the same rotation). Must be smooth enough that
        consecutive samples differ by less than 180 deg.
    dt : float
        Sample time, s.
    frame : {"NED", "ENU"}
        Earth frame of ``quat``, ``ext_acc`` and ``mag_field``.
    rng : numpy.random.Generator, optional
        Source of every random number; required when any noise or the bias walk is non-zero.
    gyr_noise : float
        White-noise density of the gyroscope, rad/s/sqrt(Hz); per-sample standard deviation
        ``gyr_noise / sqrt(dt)`` (``mu_k`` of eq. 7).
    acc_noise : float
        White-noise density of the accelerometer, m/s^2/sqrt(Hz) (``nu_k`` of eq. 9).
    mag_noise : float
        White-noise density of the magnetometer, field unit/sqrt(Hz) (``eps_k`` of eq. 9).
    gyr_bias : (3,) array_like
        Initial gyroscope bias ``b_0``, rad/s.
    gyr_bias_walk : float
        Rate random walk density, rad/s^2/sqrt(Hz): ``eta_k`` has standard deviation
        ``gyr_bias_walk * sqrt(dt)`` per axis.
    ext_acc : ndarray (N, 3) or (3,), optional
        External (kinematic) acceleration of the sensor in the earth frame, m/s^2.
    mag_field : None, False, (3,) or (N, 3)
        Earth magnetic field in the earth frame. None: :func:`earth_field` (magnitude 1,
        inclination :data:`DEFAULT_INCLINATION_DEG`); False: no magnetometer (``mag`` is None).
    mag_perturbation : ndarray (N, 3), optional
        Additive magnetic disturbance in the **sensor** frame (a field source carried with the
        sensor or met along the way, FAEKF paper Fig. 7), same unit as the field.
    g : float
        Gravity, m/s^2.
    name : str
        Recording name.
    acc_bias, mag_bias : (3,) array_like
        Constant biases ``a_0`` and ``h_0`` of eq. 9.
    gyr_scale, acc_scale : None, (3,) or (3, 3)
        Scale-factor errors ``dS`` of eqs. 7/9 (a (3,) vector is the diagonal). None: zero.
    gyr_misalignment, acc_misalignment : None or (3, 3)
        Misalignment matrices ``M`` of eqs. 7/9. None: identity.
    motion : ndarray (N,) bool, optional
        Samples the metrics use; all by default.
    extra : dict, optional
        More named (N, ...) signals to store in the recording.
    source : str
        Description for error messages; defaults to ``"simulate_imu"``.

    Returns
    -------
    Recording
        ``gyr`` rad/s, ``acc`` m/s^2, ``mag`` (unit of the field, "1" by default), ``quat`` the
        normalised sign-continuous truth, ``extra`` with ``true_gyr`` (N, 3) the exact body rate,
        ``gyr_bias`` (N, 3) the true bias, ``true_ext_acc`` (N, 3) earth-frame external acceleration
        and ``mag_disturbance`` (N, 3) when given, plus ``extra``.
    """
    _check_frame(frame)
    q = np.asarray(quat, dtype=float)
    if q.ndim != 2 or q.shape[1] != 4 or q.shape[0] < 2:
        raise ValueError(f"quat must have shape (N, 4) with N >= 2, got {q.shape}")
    if not np.isfinite(q).all():
        raise ValueError("quat must be finite (the truth of a simulation is known everywhere)")
    norms = np.linalg.norm(q, axis=1)
    if np.any(norms < 0.5):
        raise ValueError(f"quat must hold unit quaternions, smallest norm is {norms.min():.3g}")
    try:
        dt = float(dt)
    except (TypeError, ValueError):
        raise ValueError(f"dt must be a positive number of seconds, got {dt!r}") from None
    if not (np.isfinite(dt) and dt > 0):
        raise ValueError(f"dt must be a positive number of seconds, got {dt!r}")
    n = q.shape[0]
    q = _make_continuous(q / norms[:, None])

    gyr_noise = _nonneg("gyr_noise", gyr_noise)
    acc_noise = _nonneg("acc_noise", acc_noise)
    mag_noise = _nonneg("mag_noise", mag_noise)
    gyr_bias_walk = _nonneg("gyr_bias_walk", gyr_bias_walk)
    needs_rng = (gyr_noise > 0 or acc_noise > 0 or gyr_bias_walk > 0
                 or (mag_noise > 0 and mag_field is not False))
    if needs_rng and not isinstance(rng, np.random.Generator):
        raise ValueError("noise or bias walk requested: pass rng=numpy.random.default_rng(seed)")

    # --- gyroscope, eq. 7 ---
    w_true = body_rate(q, dt)
    gyr = w_true
    m_g = _mat3("gyr_misalignment", gyr_misalignment)
    s_g = _mat3("gyr_scale", gyr_scale)
    if m_g is not None or s_g is not None:
        gain = (np.eye(3) + (s_g if s_g is not None else 0.0)) @ (m_g if m_g is not None else np.eye(3))
        gyr = gyr @ gain.T
    bias = np.broadcast_to(_vec3("gyr_bias", gyr_bias), (n, 3)).copy()
    if gyr_bias_walk > 0:
        eta = rng.standard_normal((n, 3)) * (gyr_bias_walk * math.sqrt(dt))
        eta[0] = 0.0
        bias += np.cumsum(eta, axis=0)
    gyr = gyr + bias
    if gyr_noise > 0:
        gyr = gyr + rng.standard_normal((n, 3)) * (gyr_noise / math.sqrt(dt))

    # --- accelerometer, eq. 9 ---
    f_earth = np.broadcast_to(earth_gravity(frame, g), (n, 3))
    ext = None
    if ext_acc is not None:
        ext = np.broadcast_to(_vec3("ext_acc", ext_acc, n), (n, 3))
        if not np.isfinite(ext).all():
            raise ValueError("ext_acc must be finite")
        f_earth = f_earth + ext
    acc = rotate(q, f_earth, inverse=True)
    m_a = _mat3("acc_misalignment", acc_misalignment)
    s_a = _mat3("acc_scale", acc_scale)
    if m_a is not None or s_a is not None:
        gain = (np.eye(3) + (s_a if s_a is not None else 0.0)) @ (m_a if m_a is not None else np.eye(3))
        acc = acc @ gain.T
    acc = acc + _vec3("acc_bias", acc_bias)
    if acc_noise > 0:
        acc = acc + rng.standard_normal((n, 3)) * (acc_noise / math.sqrt(dt))

    # --- magnetometer, eq. 9 ---
    mag = None
    ex = {"true_gyr": w_true, "gyr_bias": bias}
    if ext is not None:
        ex["true_ext_acc"] = np.array(ext)
    if mag_field is not False:
        h = earth_field(frame) if mag_field is None else _vec3("mag_field", mag_field, n)
        mag = rotate(q, np.broadcast_to(h, (n, 3)), inverse=True)
        if mag_perturbation is not None:
            mp = np.asarray(mag_perturbation, dtype=float)
            if mp.shape != (n, 3):
                raise ValueError(f"mag_perturbation must have shape ({n}, 3), got {mp.shape}")
            mag = mag + mp
            ex["mag_disturbance"] = mp
        mag = mag + _vec3("mag_bias", mag_bias)
        if mag_noise > 0:
            mag = mag + rng.standard_normal((n, 3)) * (mag_noise / math.sqrt(dt))
    elif mag_perturbation is not None:
        raise ValueError("mag_perturbation given but mag_field=False (no magnetometer)")
    if extra:
        ex.update(extra)
    return Recording(
        name=name, gyr=gyr, acc=acc, mag=mag, dt=dt, quat=q, motion=motion, frame=frame,
        units={"gyr": "rad/s", "acc": "m/s^2", "mag": "1" if mag_field is None else "field unit"},
        source=source or "simulate_imu", extra=ex,
    )


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


def _euler_zyx_to_quat(roll: np.ndarray, pitch: np.ndarray, yaw: np.ndarray) -> np.ndarray:
    """Sensor-to-earth quaternion ``q = qz(yaw) qy(pitch) qx(roll)`` (ZYX, FAEKF paper eqs. 4-6)."""
    cr, sr = np.cos(roll / 2), np.sin(roll / 2)
    cp, sp = np.cos(pitch / 2), np.sin(pitch / 2)
    cy, sy = np.cos(yaw / 2), np.sin(yaw / 2)
    return np.stack([
        cy * cp * cr + sy * sp * sr,
        cy * cp * sr - sy * sp * cr,
        cy * sp * cr + sy * cp * sr,
        sy * cp * cr - cy * sp * sr,
    ], axis=1)


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
    n = int(round(duration_s * rate_hz))
    if n < 16:
        raise ValueError(f"duration_s * rate_hz gives {n} samples; need at least 16")
    return n, 1.0 / rate_hz


# ----------------------------------------------------------------------------------------------
# the 6-DOF bench of the FAEKF paper, section 5.1
# ----------------------------------------------------------------------------------------------
#: Default sensor model of :func:`bench6dof` with ``noise=True`` (MPU-9250-class MEMS MARG; the
#: paper's Gazebo plugins do not state their noise parameters in the text).
BENCH6DOF_SENSOR = {
    "gyr_noise": 1.75e-4,      # rad/s/sqrt(Hz)  (0.01 deg/s/sqrt(Hz))
    "gyr_bias_walk": 1.0e-4,   # rad/s^2/sqrt(Hz)
    "gyr_bias_max": 0.01,      # rad/s, initial bias uniform in +-this per axis
    "acc_noise": 2.94e-3,      # m/s^2/sqrt(Hz)  (300 ug/sqrt(Hz))
    "mag_noise": 1.0e-3,       # (unit field)/sqrt(Hz)
}


def bench6dof(
    duration_s: float = 60.0,
    rate_hz: float = 1000.0,
    seed: int = 0,
    *,
    vibration: bool = True,
    external_acc: bool = True,
    mag_perturbation: bool = True,
    frame: str = "NED",
    noise: bool = True,
    vib_freq_range_hz: tuple[float, float] = (1.0, 8.0),
    ext_acc_max_g: float = 2.0,
    mag_pert_range: tuple[float, float] = (0.5, 5.0),
    phase_s: tuple[float, float] = (4.0, 10.0),
    start_static_s: float = 3.0,
    **sensor_overrides,
) -> Recording:
    """Synthetic recording of the FAEKF paper's 6-DOF test bench (section 5.1).

    The paper's bench is a Gazebo model: three revolute joints follow sinusoidal references whose
    amplitude and frequency vary randomly, three prismatic joints follow random references with
    random frequencies (external accelerations), MARG sensors sample at 1 kHz, and magnetic
    perturbations from the generator of eq. 34 are added to random sections of the magnetometer
    signal. Here the joint motion is generated directly (no PID loop):

    - The recording is a sequence of phases of random length in ``phase_s`` (s), cycling through
      random permutations of :data:`PHASES`: ``static`` (attitude frozen), ``calm`` (slow rotation
      only), ``vibrating``, ``accelerating``, ``magnetic``, ``vibrating+accelerating``, ``disturbed``
      (all three). Transitions ramp over 0.5 s. The first ``start_static_s`` seconds are a
      ``static`` phase (the bench starts from rest, as a measurement run does: the filters
      initialise from the first accelerometer and magnetometer sample, which must not be disturbed).
    - Slow rotation everywhere except static phases: roll and pitch within +-0.8 rad, yaw within
      +-2.5 rad, frequencies 0.02-0.4 Hz.
    - Vibration: oscillation on all three axes with one common frequency ``f(t)`` varying in
      ``vib_freq_range_hz`` (the paper's range is 0-8 Hz), amplitudes 0.03-0.3 rad per axis, the
      amplitude capped so that each axis' rate stays within 20 rad/s (paper: +-50 rad/s overall).
    - External acceleration (earth frame): each axis within ``+-ext_acc_max_g * g``, 0.3-3 Hz. The
      paper quotes +-16 g for its bench; the default 2 g is a deliberate, documented reduction
      that keeps the accelerometer informative between bursts (pass ``ext_acc_max_g=16`` for the
      paper's extreme).
    - Magnetic perturbation (sensor frame) in ``magnetic`` and ``disturbed`` phases: eq. 34 with a
      random peak in ``mag_pert_range`` (unit earth field; the paper's range is 0-5), faded in
      and out over 0.5 s.
    - Sensors (eqs. 7 and 9) with :data:`BENCH6DOF_SENSOR` when ``noise`` (initial gyro bias drawn
      uniformly in +-``gyr_bias_max`` rad/s per axis); all zero when not.

    Components come from independent streams spawned from ``seed``: switching ``vibration``,
    ``external_acc`` or ``mag_perturbation`` off leaves the other signals' random draws unchanged.

    Parameters
    ----------
    duration_s, rate_hz : float
        Length, s, and sampling rate, Hz.
    seed : int
        Seed of ``numpy.random.SeedSequence``; same seed, bit-identical recording.
    vibration, external_acc, mag_perturbation : bool
        Switch the disturbances on or off (the phase schedule is kept; a switched-off disturbance
        leaves its phases calm).
    frame : {"NED", "ENU"}
        Earth frame of truth, external acceleration and field.
    noise : bool
        Sensor noise and bias on (defaults above) or off (exact data).
    vib_freq_range_hz, ext_acc_max_g, mag_pert_range, phase_s
        Ranges described above.
    start_static_s : float
        Length of the static phase the recording starts with, s (0: start in a random phase).
    **sensor_overrides
        Keywords of :func:`simulate_imu` overriding the sensor model (``gyr_noise``, ``acc_noise``,
        ``mag_noise``, ``gyr_bias``, ``gyr_bias_walk``, ``g``, ``acc_bias``, ``mag_bias``,
        ``gyr_scale``, ``gyr_misalignment``, ``acc_scale``, ``acc_misalignment``, ``mag_field``).

    Returns
    -------
    Recording
        ``extra``: ``true_ext_acc`` (N, 3) m/s^2 earth frame; ``mag_disturbance`` (N, 3) sensor
        frame, field unit; ``vib_freq_hz`` (N,) the oscillation frequency where vibration is on
        (envelope > 0.5), else 0; ``phase`` (N,) index into :data:`PHASES`; ``true_gyr``,
        ``gyr_bias`` (N, 3) rad/s.
    """
    _check_frame(frame)
    _check_overrides("bench6dof", sensor_overrides, _SENSOR_KEYS)
    n, dt = _check_duration(duration_s, rate_hz)
    if ext_acc_max_g < 0:
        raise ValueError(f"ext_acc_max_g must be >= 0, got {ext_acc_max_g!r}")
    g = float(sensor_overrides.get("g", 9.81))
    r_sched, r_slow, r_vib, r_acc, r_mag, r_sens = (
        np.random.default_rng(s) for s in np.random.SeedSequence(seed).spawn(6))

    if not (np.isfinite(start_static_s) and start_static_s >= 0):
        raise ValueError(f"start_static_s must be a finite number >= 0, got {start_static_s!r}")
    codes, spans = _schedule(n, dt, r_sched, phase_s, tuple(range(len(PHASES))))
    n0 = min(n, int(round(start_static_s / dt)))
    if n0 > 0:  # the bench starts at rest: the first n0 samples become a static phase
        codes[:n0] = 0
        spans = [(0, n0, 0)] + [(max(a, n0), b, c) for a, b, c in spans if b > n0]
    table = np.array([p[1:] for p in PHASES], dtype=float)
    ramp = max(2, int(round(0.5 / dt)))
    env_vib = _smooth(table[codes, 0], ramp) * vibration
    env_acc = _smooth(table[codes, 1], ramp) * external_acc
    speed = _smooth(table[codes, 3], ramp)

    slow = _slow_angles(n, dt, r_slow, np.array([0.8, 0.8, 2.5]), speed)
    vib, f_vib = _oscillation(n, dt, r_vib, vib_freq_range_hz, (0.03, 0.3), 20.0, 3)
    ang = slow + env_vib[:, None] * vib
    quat = _euler_zyx_to_quat(ang[:, 0], ang[:, 1], ang[:, 2])
    ext = env_acc[:, None] * _translation_acc(n, dt, r_acc, ext_acc_max_g * g, 3)

    mag_dist = np.zeros((n, 3))
    lo, hi = mag_pert_range
    if not (0 <= lo <= hi):
        raise ValueError(f"mag_pert_range must be (low, high) with 0 <= low <= high, got {mag_pert_range!r}")
    for start, stop, code in spans:
        if PHASES[code][3] and stop - start >= 16:
            m = magnetic_perturbation(stop - start, dt, r_mag, axes=3, amplitude=r_mag.uniform(lo, hi))
            if mag_perturbation:
                mag_dist[start:stop] = m * _fade(stop - start, ramp)[:, None]

    sensor = {}
    if noise:
        sensor = {k: v for k, v in BENCH6DOF_SENSOR.items() if k != "gyr_bias_max"}
        sensor["gyr_bias"] = r_sens.uniform(-1, 1, 3) * BENCH6DOF_SENSOR["gyr_bias_max"]
    sensor.update(sensor_overrides)
    with_mag = sensor.get("mag_field", None) is not False
    spec = (f"bench6dof(duration_s={duration_s}, rate_hz={rate_hz}, seed={seed}, vibration={vibration}, "
            f"external_acc={external_acc}, mag_perturbation={mag_perturbation}, noise={noise})")
    return simulate_imu(
        quat, dt, frame=frame, rng=r_sens, ext_acc=ext,
        mag_perturbation=mag_dist if with_mag else None, name=f"bench6dof-{seed}", source=spec,
        extra={"vib_freq_hz": np.where(env_vib > 0.5, f_vib, 0.0), "phase": codes.astype(float),
               "mag_disturbance": mag_dist},
        **sensor,
    )


# ----------------------------------------------------------------------------------------------
# the 1-D tilt bench of the thesis, section 3.1.2
# ----------------------------------------------------------------------------------------------
#: Default sensor model of :func:`tilt1d` with ``noise=True``: the thesis robot's L3G4200D gyroscope
#: (0.03 deg/s/sqrt(Hz) datasheet noise density) and LIS331DL accelerometer (8 bit, +-2 g, 18 mg
#: per digit). The thesis gives no noise numbers of its own (eqs. 3.2-3.4 define only the units);
#: the bias is chosen to match its reported gyro drift (about 15 deg after 100 s, 40 deg after 300 s),
#: the accelerometer noise density (not in the LIS331DL datasheet) is a documented choice.
TILT1D_SENSOR = {
    "gyr_noise": 5.24e-4,      # rad/s/sqrt(Hz)  (0.03 deg/s/sqrt(Hz))
    "gyr_bias_max": 2.6e-3,    # rad/s  (0.15 deg/s), initial bias uniform in +-this
    "gyr_bias_walk": 2.0e-5,   # rad/s^2/sqrt(Hz)
    "acc_noise": 2.2e-3,       # m/s^2/sqrt(Hz)  (about 220 ug/sqrt(Hz))
    "acc_resolution_g": 0.018,  # g per digit (quantisation)
    "acc_range_g": 2.0,        # saturation
}

_TILT_PHASES = (0, 1, 2, 3, 5)   # static, calm, vibrating, accelerating, vibrating+accelerating


def tilt1d(
    duration_s: float = 60.0,
    rate_hz: float = 800.0,
    seed: int = 0,
    *,
    noise: bool = True,
    frame: str = "NED",
    vibration: bool = True,
    external_acc: bool = True,
    vib_freq_range_hz: tuple[float, float] = (0.5, 6.5),
    ext_acc_max_g: float = 1.5,
    phase_s: tuple[float, float] = (4.0, 10.0),
    with_mag: bool = False,
    **sensor_overrides,
) -> Recording:
    """Synthetic recording of the thesis's 1-D tilt test bench (Odry 2020, section 3.1.2).

    The robot body (an inverted pendulum between the motors) oscillates about the wheel axle while
    the plate carrying the axle slides horizontally. Here:

    - rotation about the sensor **y** axis only: ``quat = (cos(a/2), 0, sin(a/2), 0)`` with the tilt
      angle ``a`` (rad, ``extra["angle"]``), positive by the right-hand rule about y (in NED a
      positive tilt lifts the sensor's x axis); ``gyr[:, 1]`` is the tilt rate, ``gyr[:, 0]`` and
      ``gyr[:, 2]`` carry only noise and bias;
    - external acceleration along the earth **x** axis (north in NED, east in ENU), within
      ``+-ext_acc_max_g * g`` (thesis: +-1.5 g); ``acc[:, 0]`` and ``acc[:, 2]`` carry gravity plus
      this acceleration, ``acc[:, 1]`` only noise;
    - body oscillation with frequency varying in ``vib_freq_range_hz`` (thesis: 0-6.5 Hz),
      amplitude 0.05-0.5 rad capped so the rate stays within 800 deg/s (thesis: +-800 deg/s);
      slow tilt within +-0.5 rad; phases as in :func:`bench6dof` without the magnetic ones;
    - 800 Hz sampling (thesis: "the sampling frequency is 800 Hz"); sensors of
      :data:`TILT1D_SENSOR` when ``noise`` (including 18 mg quantisation and +-2 g saturation of
      the 8-bit accelerometer).

    The thesis measures the accelerometer tilt as ``atan2(A_y, A_z)`` in its own axes; with the
    axes here the same realisation is ``atan2(acc_x, -acc_z)`` in NED and ``atan2(-acc_x, acc_z)``
    in ENU (both equal ``a`` without external acceleration and noise).

    Parameters
    ----------
    duration_s, rate_hz, seed, frame, noise, vibration, external_acc
        As in :func:`bench6dof`.
    vib_freq_range_hz, ext_acc_max_g, phase_s
        Ranges described above.
    with_mag : bool
        Also simulate a magnetometer (unit field); default no magnetometer (``mag`` is None).
    **sensor_overrides
        Keywords of :func:`simulate_imu` (see :func:`bench6dof`) plus ``acc_resolution_g`` and
        ``acc_range_g`` (None: no quantisation / saturation).

    Returns
    -------
    Recording
        ``extra``: ``angle`` (N,) rad, ``true_ext_acc`` (N, 3) m/s^2 earth frame, ``vib_freq_hz``
        (N,), ``phase`` (N,), ``true_gyr``, ``gyr_bias`` (N, 3).
    """
    _check_frame(frame)
    _check_overrides("tilt1d", sensor_overrides, _SENSOR_KEYS + ("acc_resolution_g", "acc_range_g"))
    n, dt = _check_duration(duration_s, rate_hz)
    if ext_acc_max_g < 0:
        raise ValueError(f"ext_acc_max_g must be >= 0, got {ext_acc_max_g!r}")
    r_sched, r_slow, r_vib, r_acc, r_sens = (
        np.random.default_rng(s) for s in np.random.SeedSequence(seed).spawn(5))
    codes, _ = _schedule(n, dt, r_sched, phase_s, _TILT_PHASES)
    table = np.array([p[1:] for p in PHASES], dtype=float)
    ramp = max(2, int(round(0.5 / dt)))
    env_vib = _smooth(table[codes, 0], ramp) * vibration
    env_acc = _smooth(table[codes, 1], ramp) * external_acc
    speed = _smooth(table[codes, 3], ramp)

    sensor = {}
    if noise:
        sensor = {k: v for k, v in TILT1D_SENSOR.items() if k != "gyr_bias_max"}
        sensor["gyr_bias"] = r_sens.uniform(-1, 1, 3) * TILT1D_SENSOR["gyr_bias_max"]
    sensor.update(sensor_overrides)
    g = float(sensor.get("g", 9.81))
    res_g = sensor.pop("acc_resolution_g", None)
    range_g = sensor.pop("acc_range_g", None)

    slow = _slow_angles(n, dt, r_slow, np.array([0.5]), speed)[:, 0]
    # oscillation rate capped at 740 deg/s so that with the slow tilt (< 1.3 rad/s) |rate| < 800 deg/s
    vib, f_vib = _oscillation(n, dt, r_vib, vib_freq_range_hz, (0.05, 0.5), math.radians(740.0), 1)
    angle = slow + env_vib * vib[:, 0]
    quat = np.zeros((n, 4))
    quat[:, 0] = np.cos(angle / 2)
    quat[:, 2] = np.sin(angle / 2)
    ext = np.zeros((n, 3))
    ext[:, 0] = env_acc * _translation_acc(n, dt, r_acc, ext_acc_max_g * g, 1)[:, 0]
    if not with_mag:
        sensor.setdefault("mag_field", False)
    spec = f"tilt1d(duration_s={duration_s}, rate_hz={rate_hz}, seed={seed}, noise={noise})"
    rec = simulate_imu(
        quat, dt, frame=frame, rng=r_sens, ext_acc=ext, name=f"tilt1d-{seed}", source=spec,
        extra={"angle": angle, "vib_freq_hz": np.where(env_vib > 0.5, f_vib, 0.0),
               "phase": codes.astype(float)},
        **sensor,
    )
    if res_g is None and range_g is None:
        return rec
    acc = rec.acc
    if res_g is not None:
        lsb = float(res_g) * g
        acc = np.round(acc / lsb) * lsb
    if range_g is not None:
        acc = np.clip(acc, -float(range_g) * g, float(range_g) * g)
    return replace(rec, acc=acc)


# ----------------------------------------------------------------------------------------------
# dispatcher with caches, CSV export
# ----------------------------------------------------------------------------------------------
#: Generators known to :func:`synthetic`.
GENERATORS = {"bench6dof": bench6dof, "tilt1d": tilt1d}
#: Bumped whenever a generator's output changes, so stale disk-cache files are not reused.
GENERATOR_VERSION = 2


def _freeze(name: str, value):
    """Hashable, order-independent form of a keyword value (numbers, strings, bools, None,
    sequences and arrays of them)."""
    if value is None or isinstance(value, (bool, int, float, str, np.integer, np.floating, np.bool_)):
        return value.item() if isinstance(value, np.generic) else value
    if isinstance(value, (list, tuple, np.ndarray)):
        return tuple(_freeze(name, v) for v in (value.tolist() if isinstance(value, np.ndarray) else value))
    raise ValueError(f"synthetic: keyword {name!r} must be a number, string, bool, None or a sequence "
                     f"of them (to be cached), got {type(value).__name__}")


def _thaw(value):
    return list(value) if isinstance(value, tuple) else value


def _allowed_keywords(generator: str) -> list[str]:
    import inspect
    params = inspect.signature(GENERATORS[generator]).parameters
    names = [p for p, v in params.items() if v.kind is not inspect.Parameter.VAR_KEYWORD]
    extra = list(_SENSOR_KEYS) + (["acc_resolution_g", "acc_range_g"] if generator == "tilt1d" else [])
    return names + extra


def _cache_dir() -> Path:
    env = os.environ.get("TUNER_CACHE")
    return Path(env) if env else Path.home() / ".cache" / "tuner"


def _disk_path(generator: str, key: tuple) -> Path:
    digest = hashlib.sha1(repr((GENERATOR_VERSION, generator, key)).encode()).hexdigest()[:20]
    return _cache_dir() / f"synthetic-{generator}-{digest}.npz"


def _save_npz(rec: Recording, path: Path) -> None:
    arrays = {"gyr": rec.gyr, "acc": rec.acc, "dt": np.array(rec.dt), "motion": rec.motion}
    if rec.mag is not None:
        arrays["mag"] = rec.mag
    if rec.quat is not None:
        arrays["quat"] = rec.quat
    for k, v in rec.extra.items():
        arrays[f"extra__{k}"] = v
    meta = {"name": rec.name, "frame": rec.frame, "units": dict(rec.units), "source": rec.source}
    arrays["meta"] = np.array(json.dumps(meta))
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    with open(tmp, "wb") as fh:
        np.savez(fh, **arrays)
    os.replace(tmp, path)


def _load_npz(path: Path) -> Recording:
    with np.load(path, allow_pickle=False) as z:
        meta = json.loads(str(z["meta"]))
        return Recording(
            name=meta["name"], gyr=z["gyr"], acc=z["acc"], mag=z["mag"] if "mag" in z else None,
            dt=float(z["dt"]), quat=z["quat"] if "quat" in z else None, motion=z["motion"],
            frame=meta["frame"], units=meta["units"], source=meta["source"],
            extra={k[len("extra__"):]: z[k] for k in z.files if k.startswith("extra__")},
        )


@functools.lru_cache(maxsize=16)
def _cached(generator: str, key: tuple, disk: bool) -> Recording:
    kwargs = {k: _thaw(v) for k, v in key}
    path = _disk_path(generator, key) if disk else None
    if path is not None and path.exists():
        try:
            return _load_npz(path)
        except (OSError, ValueError, KeyError):
            pass  # unreadable or partial file: regenerate and overwrite below
    rec = GENERATORS[generator](**kwargs)
    if path is not None:
        _save_npz(rec, path)
    return rec


def synthetic(generator: str, *, disk_cache: bool | None = None, **kwargs) -> Recording:
    """A synthetic recording by generator name, cached.

    Parameters
    ----------
    generator : {"bench6dof", "tilt1d"}
        Which bench (:func:`bench6dof`, :func:`tilt1d`).
    disk_cache : bool or None
        Also keep the recording as ``.npz`` in ``$TUNER_CACHE`` (default ``~/.cache/tuner``) and
        reuse it across processes. None: only when the ``TUNER_CACHE`` environment variable is set.
    **kwargs
        The generator's keywords (numbers, strings, bools, None, sequences); unknown ones are a
        ``ValueError`` that lists the allowed ones.

    Returns
    -------
    Recording
        The same object for repeated calls with equal keywords in one process (an in-process LRU
        cache of 16 recordings); treat its arrays as read-only.
    """
    if generator not in GENERATORS:
        raise ValueError(f"unknown synthetic generator {generator!r}; allowed: {', '.join(GENERATORS)}")
    allowed = _allowed_keywords(generator)
    bad = sorted(set(kwargs) - set(allowed))
    if bad:
        raise ValueError(f"synthetic generator {generator!r}: unknown keyword(s) {bad}; "
                         f"allowed: {', '.join(allowed)}")
    key = tuple(sorted((k, _freeze(k, v)) for k, v in kwargs.items()))
    disk = bool(os.environ.get("TUNER_CACHE")) if disk_cache is None else bool(disk_cache)
    return _cached(generator, key, disk)


def csv_columns(rec: Recording) -> list[str]:
    """Column names :func:`to_csv` writes for ``rec``, in order."""
    cols = ["t", "gyr_x", "gyr_y", "gyr_z", "acc_x", "acc_y", "acc_z"]
    if rec.mag is not None:
        cols += ["mag_x", "mag_y", "mag_z"]
    if rec.quat is not None:
        cols += ["q_w", "q_x", "q_y", "q_z"]
    cols.append("motion")
    for k, v in rec.extra.items():
        if v.ndim == 1:
            cols.append(k)
        elif v.ndim == 2 and v.shape[1] == 3:
            cols += [f"{k}_{a}" for a in "xyz"]
        else:
            cols += [f"{k}_{i}" for i in range(int(np.prod(v.shape[1:])))]
    return cols


def to_csv(rec: Recording, path) -> Path:
    """Write a recording to CSV for inspection (and for the CSV loader).

    One header line of comma-separated names (:func:`csv_columns`): ``t`` (s), ``gyr_x..z``
    (rad/s), ``acc_x..z`` (m/s^2), ``mag_x..z`` (if any), ``q_w, q_x, q_y, q_z`` (truth, if any),
    ``motion`` (0/1), then every extra signal (``name`` for (N,), ``name_x..z`` for (N, 3),
    ``name_0..`` otherwise). Values use 17 significant digits, so ``numpy.loadtxt(path,
    delimiter=",", skiprows=1)`` gives the arrays back bit for bit. Frame and units are not in
    the file: frame is ``rec.frame``, units those of :class:`Recording`.

    Returns
    -------
    pathlib.Path
        The path written.
    """
    path = Path(path)
    blocks = [rec.time[:, None], rec.gyr, rec.acc]
    if rec.mag is not None:
        blocks.append(rec.mag)
    if rec.quat is not None:
        blocks.append(rec.quat)
    blocks.append(rec.motion.astype(float)[:, None])
    for v in rec.extra.values():
        blocks.append(v.reshape(rec.n, -1))
    data = np.concatenate(blocks, axis=1)
    cols = csv_columns(rec)
    path.parent.mkdir(parents=True, exist_ok=True)
    np.savetxt(path, data, delimiter=",", header=",".join(cols), comments="", fmt="%.17g")
    return path
