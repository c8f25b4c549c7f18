"""The IMU sensor model: readings of a known orientation trajectory (FAEKF paper eqs. 7 and 9).

Everything here is plain vectorised NumPy or the project's quaternion kernels
(:mod:`objectives.attitude.quaternion`), and every random number comes from a
:class:`numpy.random.Generator`; the same inputs give bit-identical readings.

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

import math

import numpy as np

from objectives.attitude.data.recording import Recording
from objectives.attitude.quaternion import make_continuous, qconj_batch, qlog_batch, qmul_batch, qrot_batch

__all__ = ["simulate_imu", "body_rate", "earth_gravity", "earth_field", "DEFAULT_INCLINATION_DEG"]

#: Default magnetic inclination (dip), degrees: Budapest is about 63-64 deg (IGRF 2020).
DEFAULT_INCLINATION_DEG = 63.5

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


def _scale_and_misalign(signal: np.ndarray, sensor: str, scale, misalignment) -> np.ndarray:
    """``(I + dS) M signal`` row by row (eqs. 7 and 9); unchanged when both are None."""
    m = _mat3(f"{sensor}_misalignment", misalignment)
    ds = _mat3(f"{sensor}_scale", scale)
    if m is None and ds is None:
        return signal
    gain = (np.eye(3) + (ds if ds is not None else 0.0)) @ (m if m is not None else np.eye(3))
    return signal @ gain.T


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
    dq = qmul_batch(qconj_batch(quat[:-1]), quat[1:])
    w = qlog_batch(dq) / dt  # the rotation vector of dq over dt
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
    q = make_continuous(q / norms[:, None])

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
    gyr = _scale_and_misalign(gyr, "gyr", gyr_scale, gyr_misalignment)
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
    acc = qrot_batch(q, f_earth, inverse=True)
    acc = _scale_and_misalign(acc, "acc", acc_scale, acc_misalignment)
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
        mag = qrot_batch(q, np.broadcast_to(h, (n, 3)), inverse=True)
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
