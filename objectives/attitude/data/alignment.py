"""Alignment of a recording's ground truth to its IMU: time lag, IMU-to-marker rotation, earth-frame offset.

An optical reference tracks a marker, not the IMU: its stamps lag the IMU's, the marker's axes are not the
sensor's, and its earth frame is the camera system's, not the one the IMU's accelerometer and magnetometer
define. The ``align:`` block of a ``csv:`` data spec (:mod:`objectives.attitude.data.csv`) states or estimates
the three, and the truth becomes ``q = q_frame * q_marker(t + lag) * q_body``::

    align:
      lag: auto            # or seconds: the truth row stamped t shows the pose at t - lag (> 0: truth late)
      body: auto           # or none, or [w, x, y, z]: the sensor-to-marker rotation
      heading: start       # or mean, or none: the truth frame's offset from the IMU's earth frame
      max_lag_s: 0.5       # the largest |lag| auto searches

Model (rates in rad/s; ``w`` the marker's body rate from the truth, the gyroscope's convention of
:mod:`objectives.attitude.data.imu_model`: the rate over each step, placed at its middle)::

    gyr(t) = k M w(t + lag) + b,     M = R_body^T (marker axes -> sensor axes)

``lag: auto``
    Coarse: the peak of the cross-correlation of the gyroscope's norm with the truth rate's norm (both free of
    the unknown rotation), refined to a fraction of a sample by a parabola through the peak. Fine: Gauss-Newton
    steps on the vector residual of the model, ``dlag = sum r . J / sum J . J`` with ``J = k M dw/dt``,
    alternated with the rotation fit.
``body: auto``
    ``M``, ``k`` and ``b`` by the closed-form least-squares similarity of Umeyama (IEEE TPAMI 13(4), 1991,
    eqs. 40-42): the SVD of the cross-covariance of gyroscope and truth rates over the samples in motion (truth
    rate above :data:`MOTION_RAD_S`). It needs rotation about at least two axes (the second singular value at
    least :data:`MIN_SPREAD` of the first). ``k`` is the gyroscope's scale against the truth (1: exact; 0.97:
    the gyroscope reads 3 % low), reported with a per-axis scale and the bias ``b``, never applied.
``heading: start | mean``
    The IMU's own gravity (accelerometer) and field (magnetometer) directions, rotated into the truth frame by
    the aligned truth and averaged, give the truth frame's up and north; TRIAD (FAEKF paper eqs. 11-14) of the
    two is the rotation from the truth frame into the recording's ``frame``. ``start`` averages the rest the
    recording starts with (samples until the gyroscope norm first exceeds 0.1 rad/s or ``| |acc| - g |`` 1.0
    m/s^2, the start-in-motion thresholds of :mod:`objectives.attitude.data.plausibility`, at least
    :data:`START_MIN_S` and at most :data:`START_MAX_S`); ``mean`` every sample (external accelerations and
    field disturbances must average out). The rotation is reported as the heading offset (its twist about the
    earth's vertical) and the frame tilt (the rest: zero for a truth frame with a vertical z axis, the start
    pose's tilt for a truth relative to its start pose).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from objectives.attitude.data.recording import RecordingError
from objectives.attitude.data.timebase import body_rates, slerp

__all__ = ["AlignSpec", "Alignment", "estimate_alignment", "alignments", "ALIGN_KEYS", "MOTION_RAD_S", "MIN_SPREAD",
           "START_MIN_S", "START_MAX_S"]

#: the keys of an ``align:`` block
ALIGN_KEYS = ("lag", "body", "heading", "max_lag_s")
#: truth rate (rad/s) above which a sample is in motion for the rotation fit
MOTION_RAD_S = 0.2
#: smallest ratio of the second to the first singular value of the rate cross-covariance for body: auto
MIN_SPREAD = 0.02
#: the start window of heading: start, s
START_MIN_S = 0.25
START_MAX_S = 30.0
_G = 9.80665
_IDENTITY = (1.0, 0.0, 0.0, 0.0)


@dataclass(frozen=True)
class AlignSpec:
    """An ``align:`` block: ``lag`` "auto" or s, ``body`` "auto", "none" or (w, x, y, z), ``heading`` "start",
    "mean" or "none", ``max_lag_s`` s."""

    lag: Any = 0.0
    body: Any = "none"
    heading: str = "none"
    max_lag_s: float = 0.5

    @classmethod
    def from_config(cls, value: Any, where: str) -> AlignSpec:
        """The block ``value`` checked; RecordingError naming ``where`` (``file: align``) and the key."""
        if not isinstance(value, Mapping):
            raise RecordingError(f"{where}: expected a mapping with keys {', '.join(ALIGN_KEYS)}, got {value!r}")
        bad = sorted(set(value) - set(ALIGN_KEYS))
        if bad:
            raise RecordingError(f"{where}.{bad[0]}: unknown key; allowed: {', '.join(ALIGN_KEYS)}")
        lag = value.get("lag", 0.0)
        if not (lag == "auto" or (_number(lag) and math.isfinite(lag))):
            raise RecordingError(f"{where}.lag: expected auto or a number of seconds, got {lag!r}")
        body = value.get("body", "none")
        if body not in ("auto", "none"):
            q = np.asarray(body, dtype=float) if _numbers(body) else np.zeros(0)
            if q.shape != (4,) or not np.isfinite(q).all() or abs(np.linalg.norm(q) - 1.0) > 0.01:
                raise RecordingError(f"{where}.body: expected auto, none or a unit quaternion [w, x, y, z] (the "
                                     f"sensor-to-marker rotation), got {body!r}")
            body = tuple(float(x) for x in q / np.linalg.norm(q))
        heading = value.get("heading", "none")
        if heading not in ("start", "mean", "none"):
            raise RecordingError(f"{where}.heading: expected start, mean or none, got {heading!r}")
        max_lag = value.get("max_lag_s", 0.5)
        if not (_number(max_lag) and 0 < max_lag < math.inf):
            raise RecordingError(f"{where}.max_lag_s: expected a number of seconds > 0, got {max_lag!r}")
        return cls(lag if lag == "auto" else float(lag), body, heading, float(max_lag))


def _number(v: Any) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool)


def _numbers(v: Any) -> bool:
    return isinstance(v, (list, tuple)) and all(_number(x) for x in v)


@dataclass(frozen=True)
class Alignment:
    """Applied and estimated alignment of one recording (``Recording.meta["alignment"]``, module docstring).

    Attributes
    ----------
    lag_s : float
        The truth's lag behind the IMU, s (the row stamped t shows the pose at t - lag_s).
    body : (4,) tuple
        Sensor-to-marker rotation ``(w, x, y, z)``; ``body_angle_deg`` its angle.
    frame : (4,) tuple
        Rotation from the truth's earth frame into the recording's; ``heading_offset_deg`` its twist about
        the vertical (counter-clockwise about the frame's z axis), ``frame_tilt_deg`` the rest.
    gyro_scale : float
        ``k`` of the model: the gyroscope's reading over the truth's rate (NaN without motion);
        ``gyro_scale_axes`` per sensor axis; ``gyro_bias_rad_s`` the offset ``b``.
    rate_residual_rad_s : float
        RMS of ``gyr - (k M w + b)`` over ``motion_samples`` samples in motion.
    estimated : tuple of str
        Which of ``lag``, ``body``, ``heading`` were estimated (the others were given or none).
    """

    lag_s: float = 0.0
    body: tuple = _IDENTITY
    body_angle_deg: float = 0.0
    frame: tuple = _IDENTITY
    heading_offset_deg: float = 0.0
    frame_tilt_deg: float = 0.0
    gyro_scale: float = math.nan
    gyro_scale_axes: tuple = (math.nan, math.nan, math.nan)
    gyro_bias_rad_s: tuple = (math.nan, math.nan, math.nan)
    rate_residual_rad_s: float = math.nan
    motion_samples: int = 0
    estimated: tuple = ()

    def as_dict(self) -> dict[str, Any]:
        """Plain values (floats, lists) for a run's records."""
        out: dict[str, Any] = {}
        for k, v in self.__dict__.items():
            out[k] = [float(x) if _number(x) else x for x in v] if isinstance(v, tuple) else v
        return out

    def truth(self, t: np.ndarray, t_truth: np.ndarray, q_truth: np.ndarray, max_gap_s: float) -> np.ndarray:
        """The aligned truth at times ``t`` (N,): ``frame * slerp(q_truth, t + lag) * body`` (N, 4)."""
        from objectives.attitude.quaternion import qmul_batch

        q = slerp(t_truth, q_truth, t + self.lag_s, max_gap_s)
        ok = np.isfinite(q).all(axis=1)
        out = np.full_like(q, np.nan)
        if ok.any():
            out[ok] = qmul_batch(np.asarray(self.frame), qmul_batch(q[ok], np.asarray(self.body)))
        return out


# --- the estimates ----------------------------------------------------------------------------------------
class _Rates:
    """The truth's body rates and their time derivative, interpolated at the gyroscope's step middles."""

    def __init__(self, t: np.ndarray, t_truth: np.ndarray, q_truth: np.ndarray, max_gap_s: float):
        self.mid, self.w = body_rates(t_truth, q_truth, max_gap_s)
        self.dw = np.column_stack([np.gradient(self.w[:, j], self.mid) for j in range(3)]) \
            if self.mid.shape[0] > 2 else np.full_like(self.w, np.nan)
        self.query = t + 0.5 * float(np.median(np.diff(t)))

    def at(self, lag: float, deriv: bool = False) -> np.ndarray:
        src = self.dw if deriv else self.w
        x = self.query + lag
        out = np.column_stack([np.interp(x, self.mid, src[:, j], left=np.nan, right=np.nan) for j in range(3)])
        return out


def _coarse_lag(gyr: np.ndarray, rates: _Rates, dt: float, max_lag_s: float, where: str) -> float:
    """The lag (s) at the peak of the cross-correlation of the rate norms, with a parabolic refinement."""
    from scipy.fft import irfft, next_fast_len, rfft

    x = np.linalg.norm(gyr, axis=1)
    y = np.linalg.norm(rates.at(0.0), axis=1)
    ok = np.isfinite(y)
    if ok.sum() < 10 or np.std(x[ok]) < 0.05:
        raise RecordingError(f"{where}.lag: auto needs motion with the truth present (the gyroscope norm varies by "
                             f"{np.std(x[ok]) if ok.any() else 0.0:.3g} rad/s over {int(ok.sum())} samples); "
                             "give the lag in seconds")
    xs = np.where(ok, x - x[ok].mean(), 0.0)
    ys = np.where(ok, y - np.nanmean(y[ok]), 0.0)
    n = x.shape[0]
    nfft = next_fast_len(2 * n)
    c = irfft(np.conj(rfft(xs, nfft)) * rfft(ys, nfft), nfft)  # c[m] = sum_k x_k y_(k+m), circular
    kmax = max(1, min(n - 2, int(max_lag_s / dt)))
    lags = np.arange(-kmax, kmax + 1)
    vals = c[lags % nfft]
    i = int(np.argmax(vals))
    frac = 0.0
    if 0 < i < vals.shape[0] - 1:
        a, b, d = vals[i - 1], vals[i], vals[i + 1]
        den = a - 2.0 * b + d
        frac = 0.5 * (a - d) / den if den < 0 else 0.0
    return float((lags[i] + frac) * dt)


def _similarity(x: np.ndarray, y: np.ndarray, rotation: np.ndarray | None) -> tuple[np.ndarray, float, np.ndarray,
                                                                                      np.ndarray]:
    """``y ~ k M x + b`` by least squares over rows of ``x``, ``y`` (n, 3): ``(M, k, b, singular values)``;
    with ``rotation`` given, ``M`` is it and only ``k``, ``b`` are fitted (Umeyama 1991, eqs. 40-42)."""
    mx, my = x.mean(axis=0), y.mean(axis=0)
    xc, yc = x - mx, y - my
    var = float(np.mean(np.sum(xc * xc, axis=1)))
    cov = yc.T @ xc / x.shape[0]
    u, s, vt = np.linalg.svd(cov)
    if rotation is None:
        d = np.diag([1.0, 1.0, np.sign(np.linalg.det(u) * np.linalg.det(vt)) or 1.0])
        m = u @ d @ vt
        k = float(np.trace(np.diag(s) @ d) / var)
    else:
        m = rotation
        z = xc @ m.T
        k = float(np.sum(yc * z) / np.sum(z * z))
    return m, k, my - k * (m @ mx), s


def _fit(gyr: np.ndarray, w: np.ndarray, body: Any, where: str) -> tuple[np.ndarray, float, np.ndarray, np.ndarray]:
    """The model's ``(M, k, b, motion mask)`` with the truth rates ``w`` (N, 3) at the gyroscope's steps."""
    moving = np.isfinite(w).all(axis=1) & (np.linalg.norm(np.nan_to_num(w), axis=1) > MOTION_RAD_S)
    if moving.sum() < 20:
        raise RecordingError(f"{where}: the truth moves faster than {MOTION_RAD_S} rad/s in {int(moving.sum())} "
                             "samples; estimating the alignment needs motion (give lag and body instead)")
    fixed = None if body == "auto" else _matrix(_IDENTITY if body == "none" else body).T
    m, k, b, s = _similarity(w[moving], gyr[moving], fixed)
    if body == "auto" and s[1] < MIN_SPREAD * s[0]:
        raise RecordingError(f"{where}.body: auto needs rotation about at least two axes; the rates span one "
                             f"(singular values {s[0]:.3g}, {s[1]:.3g}, {s[2]:.3g}); give body: [w, x, y, z]")
    return m, k, b, moving


def _matrix(q: Any) -> np.ndarray:
    from objectives.attitude.quaternion import rotmat

    return rotmat(np.asarray(q, dtype=float))


def _quaternion(r: np.ndarray) -> tuple:
    from scipy.spatial.transform import Rotation

    x, y, z, w = Rotation.from_matrix(r).as_quat()
    q = np.array([w, x, y, z])
    # w >= 0; within about a degree of a half turn (|w| < 0.01) the largest part > 0, so that the estimate of a
    # half turn does not print as its negative for a difference of hundredths of a degree
    lead = q[0] if abs(q[0]) >= 0.01 else q[1 + int(np.argmax(np.abs(q[1:])))]
    return tuple(float(v) for v in (q if lead >= 0 else -q))


def _angle_deg(q: tuple) -> float:
    return float(np.degrees(2.0 * math.acos(min(1.0, abs(q[0])))))


def _frame(t, gyr, acc, mag, q_sensor, heading: str, frame: str, where: str) -> tuple:
    """The rotation (w, x, y, z) from the truth frame into ``frame`` (module docstring)."""
    from objectives.attitude.quaternion import qrot_batch, triad_batch

    if mag is None:
        raise RecordingError(f"{where}.heading: {heading} needs the magnetometer (a 'mag' column map); "
                             "set heading: none")
    ok = np.isfinite(q_sensor).all(axis=1)
    if heading == "start":
        rest = (np.linalg.norm(gyr, axis=1) < 0.1) & (np.abs(np.linalg.norm(acc, axis=1) - _G) < 1.0)
        n_rest = int(np.argmin(rest)) if not rest.all() else rest.shape[0]
        dt = float(np.median(np.diff(t)))
        n = min(max(n_rest, int(round(START_MIN_S / dt))), int(round(START_MAX_S / dt)))
        ok[n:] = False
    if ok.sum() < 2:
        raise RecordingError(f"{where}.heading: {heading} finds {int(ok.sum())} samples with truth "
                             f"{'in the start window' if heading == 'start' else ''}; set heading: none or mean")
    up = qrot_batch(q_sensor[ok], acc[ok]).mean(axis=0)
    north = qrot_batch(q_sensor[ok], mag[ok]).mean(axis=0)
    q = triad_batch(up, north, frame)
    if not np.isfinite(q).all():
        raise RecordingError(f"{where}.heading: gravity and field are parallel in the truth frame; set heading: "
                             "none")
    return tuple(float(v) for v in q)


def _twist(q: tuple) -> tuple[float, float]:
    """(heading deg, tilt deg) of ``q``: its twist about the earth's z axis and the angle of the rest."""
    w, z = q[0], q[3]
    psi = 2.0 * math.atan2(z, w)
    psi = (psi + math.pi) % (2.0 * math.pi) - math.pi
    c = math.cos(psi / 2.0)
    s = math.sin(psi / 2.0)
    sw = c * q[0] + s * q[3]  # w of conj(twist) * q
    return math.degrees(psi), math.degrees(2.0 * math.acos(min(1.0, abs(sw))))


def estimate_alignment(t: np.ndarray, gyr: np.ndarray, acc: np.ndarray, mag: np.ndarray | None,
                       t_truth: np.ndarray, q_truth: np.ndarray, spec: AlignSpec, frame: str,
                       max_gap_s: float = math.inf, where: str = "align") -> Alignment:
    """The :class:`Alignment` of ``spec`` for IMU samples at uniform times ``t`` (N,) and truth rows
    ``q_truth`` (M, 4) at stamps ``t_truth`` (module docstring).

    Parameters
    ----------
    t : ndarray (N,)
        IMU sample times, s, uniform.
    gyr, acc : ndarray (N, 3)
        rad/s, m/s^2 (sensor frame).
    mag : ndarray (N, 3) or None
    t_truth, q_truth : ndarray (M,), (M, 4)
        Truth stamps (s, increasing, the clock of ``t``) and sensor- or marker-to-earth quaternions (NaN rows
        unknown).
    spec : AlignSpec
    frame : {"ENU", "NED"}
        Earth frame the IMU's gravity and field define (the recording's).
    max_gap_s : float
        Truth rows further apart are not interpolated across.
    where : str
        Prefix of error messages (``file: align``).

    Raises
    ------
    RecordingError
        An estimate the data do not determine (no motion, rotation about one axis, no magnetometer).
    """
    dt = float(np.median(np.diff(t)))
    rates = _Rates(t, t_truth, q_truth, max_gap_s)
    estimated = tuple(k for k, v in (("lag", spec.lag), ("body", spec.body)) if v == "auto")
    lag = _coarse_lag(gyr, rates, dt, spec.max_lag_s, where) if spec.lag == "auto" else float(spec.lag)
    has_motion = True
    try:
        m, k, b, moving = _fit(gyr, rates.at(lag), spec.body, where)
    except RecordingError:
        if estimated:
            raise
        has_motion = False  # nothing to estimate: the scale stays unknown
    for _ in range(3 if has_motion and spec.lag == "auto" else 0):
        for _ in range(6):  # Gauss-Newton on the lag with M, k, b held
            w, dw = rates.at(lag), rates.at(lag, deriv=True)
            r = gyr - (k * w @ m.T + b)
            jac = k * dw @ m.T
            sel = np.isfinite(r).all(axis=1) & np.isfinite(jac).all(axis=1)
            den = float(np.sum(jac[sel] * jac[sel]))
            if den <= 0:
                break
            step = float(np.clip(np.sum(r[sel] * jac[sel]) / den, -dt, dt))
            lag += step
            if abs(step) < 1e-7:
                break
        m, k, b, moving = _fit(gyr, rates.at(lag), spec.body, where)
    body = spec.body if isinstance(spec.body, tuple) else _IDENTITY
    scale, axes, bias, resid, n_moving = math.nan, (math.nan,) * 3, (math.nan,) * 3, math.nan, 0
    if has_motion:
        w = rates.at(lag)
        z = w[moving] @ m.T
        y = gyr[moving] - b
        scale, bias, n_moving = k, tuple(float(v) for v in b), int(moving.sum())
        zc, yc = z - z.mean(axis=0), y - y.mean(axis=0)
        with np.errstate(invalid="ignore", divide="ignore"):  # an axis without rotation: NaN
            axes = tuple(float(v) for v in np.sum(yc * zc, axis=0) / np.sum(zc * zc, axis=0))
        resid = float(np.sqrt(np.mean(np.sum((y - k * z) ** 2, axis=1))))
        if spec.body == "auto":
            body = _quaternion(m.T)
    out = Alignment(lag_s=float(lag), body=tuple(body), body_angle_deg=_angle_deg(body), gyro_scale=float(scale),
                    gyro_scale_axes=axes, gyro_bias_rad_s=bias, rate_residual_rad_s=resid,
                    motion_samples=n_moving, estimated=estimated)
    if spec.heading == "none":
        return out
    from objectives.attitude.quaternion import qmul_batch

    q = slerp(t_truth, q_truth, t + lag, max_gap_s)
    ok = np.isfinite(q).all(axis=1)
    q_sensor = np.full_like(q, np.nan)
    if ok.any():
        q_sensor[ok] = qmul_batch(q[ok], np.asarray(body))
    q_frame = _frame(t, gyr, acc, mag, q_sensor, spec.heading, frame, where)
    heading, tilt = _twist(q_frame)
    return Alignment(**{**out.__dict__, "frame": q_frame, "heading_offset_deg": heading, "frame_tilt_deg": tilt,
                        "estimated": (*estimated, "heading")})


def alignments(recordings: Any) -> dict[str, dict[str, Any]]:
    """``{recording name: Alignment.as_dict()}`` of the recordings read with an ``align:`` block (what a run
    stores and prints; recordings without one are left out)."""
    return {r.name: r.meta["alignment"].as_dict() for r in recordings if "alignment" in r.meta}
