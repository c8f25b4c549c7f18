"""The :class:`Recording`: IMU samples with ground truth, validated once at construction.

Conventions (shared by every filter, metric and loader of the project)
----------------------------------------------------------------------
- Quaternions are ``(w, x, y, z)``, Hamilton product, and describe the **sensor-to-earth**
  rotation: ``v_earth = q * v_sensor * conj(q)``.
- ``frame`` names the earth frame: ``"ENU"`` (x east, y north, z up; BROAD) or ``"NED"`` (x north,
  y east, z down; the FAEKF paper). See :mod:`objectives.attitude.quaternion` for conversions.
- ``gyr`` in rad/s, ``acc`` in m/s^2 (specific force: at rest the accelerometer reads +g along the
  earth's *up* axis expressed in the sensor frame), ``mag`` in any unit (filters normalise it).
- ``quat`` (truth) may hold NaN rows where the reference was lost; metrics skip them.
- ``motion`` marks the samples that metrics use (BROAD's ``movement``); all True by default.
- ``meta`` holds what a loader found and estimated while reading (not per-sample data): ``"read"`` (a
  :class:`objectives.attitude.data.timebase.ReadInfo`: dropped stamps, the IMU's own rate, truth samples
  set to NaN), ``"alignment"`` (an :class:`objectives.attitude.data.alignment.Alignment`: lag, body
  rotation, heading offset, gyro scale) and ``"warnings"`` (lines the preflight prints).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

__all__ = ["Recording", "RecordingError"]

FRAMES = ("ENU", "NED")


class RecordingError(ValueError):
    """Bad recording data: the message names the source, the field and what was expected."""


def _as_array(source: str, key: str, value: Any, ncols: int | None, n: int | None) -> np.ndarray:
    try:
        a = np.ascontiguousarray(np.asarray(value, dtype=np.float64))
    except (TypeError, ValueError) as exc:
        raise RecordingError(f"{source}: {key!r} is not numeric ({exc})") from None
    if ncols is None:
        if a.ndim == 2 and a.shape[1] == 1:
            a = np.ascontiguousarray(a[:, 0])
        if a.ndim != 1:
            raise RecordingError(f"{source}: {key!r} must have shape (N,), got {a.shape}")
    elif a.ndim != 2 or a.shape[1] != ncols:
        raise RecordingError(f"{source}: {key!r} must have shape (N, {ncols}), got {a.shape}")
    if n is not None and a.shape[0] != n:
        raise RecordingError(f"{source}: {key!r} has {a.shape[0]} samples, expected {n} (as gyr)")
    return a


def _check_finite_rows(source: str, what: str, a: np.ndarray, hint: str = "") -> None:
    """``RecordingError`` naming ``source``, ``what`` (a quoted key) and the first row of ``a`` (N, k)
    that is not all finite."""
    bad = ~np.isfinite(a).all(axis=1)
    if bad.any():
        raise RecordingError(
            f"{source}: {what} has {int(bad.sum())} non-finite sample(s), first at index {int(np.argmax(bad))}{hint}"
        )


@dataclass(frozen=True, eq=False)
class Recording:
    """IMU data of one trial plus ground truth.

    Attributes
    ----------
    name : str
        Trial name (used in metrics tables and history columns).
    gyr : ndarray (N, 3)
        Angular rate in the sensor frame, rad/s.
    acc : ndarray (N, 3)
        Specific force in the sensor frame, m/s^2.
    mag : ndarray (N, 3) or None
        Magnetic field in the sensor frame, any unit (``units["mag"]`` says which).
    dt : float
        Sample time, s (uniform sampling).
    quat : ndarray (N, 4) or None
        True sensor-to-earth orientation ``(w, x, y, z)`` in ``frame``; NaN rows are unknown.
    motion : ndarray (N,) bool
        Samples used by metrics.
    frame : {"ENU", "NED"}
        Earth frame of ``quat`` and of every filter's output on this recording.
    units : dict
        Units of the signals, e.g. ``{"gyr": "rad/s", "acc": "m/s^2", "mag": "uT"}``.
    source : str
        Where the data came from (file path or generator spec), for error messages.
    extra : dict
        Optional named signals of length N (e.g. ``{"true_ext_acc": (N, 3)}`` from a generator).
    meta : dict
        What the loader found and estimated (module docstring): ``read``, ``alignment``, ``warnings``.
    """

    name: str
    gyr: np.ndarray
    acc: np.ndarray
    mag: np.ndarray | None
    dt: float
    quat: np.ndarray | None = None
    motion: np.ndarray | None = None
    frame: str = "ENU"
    units: Mapping[str, str] = field(default_factory=lambda: {"gyr": "rad/s", "acc": "m/s^2", "mag": "1"})
    source: str = ""
    extra: Mapping[str, np.ndarray] = field(default_factory=dict)
    meta: Mapping[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        src = self.source or self.name or "recording"
        gyr = _as_array(src, "gyr", self.gyr, 3, None)
        n = gyr.shape[0]
        if n < 2:
            raise RecordingError(f"{src}: needs at least 2 samples, got {n}")
        acc = _as_array(src, "acc", self.acc, 3, n)
        for key, a in (("gyr", gyr), ("acc", acc)):
            _check_finite_rows(src, repr(key), a, "; filters need finite gyr and acc (clean or cut the recording)")
        mag = None
        if self.mag is not None:
            mag = _as_array(src, "mag", self.mag, 3, n)
            _check_finite_rows(src, "'mag'", mag)
        quat = None if self.quat is None else _as_array(src, "quat", self.quat, 4, n)
        if self.motion is None:
            motion = np.ones(n, dtype=bool)
        else:
            motion = _as_array(src, "motion", self.motion, None, n).astype(bool)
        try:
            dt = float(self.dt)
        except (TypeError, ValueError):
            raise RecordingError(f"{src}: 'dt' must be a number of seconds, got {self.dt!r}") from None
        if not (np.isfinite(dt) and dt > 0):
            raise RecordingError(f"{src}: 'dt' must be a positive number of seconds, got {self.dt!r}")
        if self.frame not in FRAMES:
            raise RecordingError(f"{src}: 'frame' must be one of {FRAMES}, got {self.frame!r}")
        extra = {}
        for k, v in dict(self.extra).items():
            a = np.ascontiguousarray(np.asarray(v, dtype=np.float64))
            if a.shape[0] != n:
                raise RecordingError(f"{src}: extra signal {k!r} has {a.shape[0]} samples, expected {n}")
            extra[k] = a
        for k, v in (("gyr", gyr), ("acc", acc), ("mag", mag), ("quat", quat), ("motion", motion),
                     ("dt", dt), ("extra", extra)):
            object.__setattr__(self, k, v)

    # ------------------------------------------------------------------------------------------
    @classmethod
    def from_time(
        cls,
        time: Any,
        *,
        name: str,
        gyr: Any,
        acc: Any,
        mag: Any = None,
        quat: Any = None,
        motion: Any = None,
        frame: str = "ENU",
        units: Mapping[str, str] | None = None,
        source: str = "",
        extra: Mapping[str, Any] | None = None,
        jitter_tol: float = 0.05,
        rate_hz: float | None = None,
        rate_tol: float = 0.01,
        meta: Mapping[str, Any] | None = None,
    ) -> Recording:
        """A recording from sample time stamps instead of ``dt``: checks them and derives ``dt``.

        Parameters
        ----------
        time : array (N,)
            Time stamps, s; finite and strictly increasing.
        jitter_tol : float
            Largest allowed deviation of any sample interval from ``dt``, as a fraction of ``dt``
            (0.05: every interval within 5 % of the mean). Filters assume uniform sampling.
        rate_hz : float, optional
            Expected sampling rate; with it, ``|1/dt - rate_hz| <= rate_tol * rate_hz`` is checked.
        rate_tol : float
            Relative tolerance of that check.
        Other parameters are those of :class:`Recording`.

        Returns
        -------
        Recording
            With ``dt = (time[-1] - time[0]) / (N - 1)``.

        Raises
        ------
        RecordingError
            Naming the source and ``'time'``: wrong shape or length, non-finite stamps, a stamp not
            after the one before it (with its index), non-uniform sampling beyond ``jitter_tol``
            (with the worst interval), or a rate away from ``rate_hz``.
        """
        src = source or name or "recording"
        t = _as_array(src, "time", time, None, None)
        n_gyr = np.shape(gyr)[0] if np.ndim(gyr) >= 1 else None
        if n_gyr is not None and t.shape[0] != n_gyr:
            raise RecordingError(f"{src}: 'time' has {t.shape[0]} samples, expected {n_gyr} (as gyr)")
        if t.shape[0] < 2:
            raise RecordingError(f"{src}: 'time' needs at least 2 samples, got {t.shape[0]}")
        bad = ~np.isfinite(t)
        if bad.any():
            raise RecordingError(f"{src}: 'time' has non-finite stamps, first at index {int(np.argmax(bad))}")
        d = np.diff(t)
        if np.any(d <= 0):
            i = int(np.argmax(d <= 0)) + 1
            raise RecordingError(
                f"{src}: 'time' must increase strictly; sample {i} at {float(t[i])!r} s follows {float(t[i - 1])!r} s"
            )
        dt = float((t[-1] - t[0]) / (t.shape[0] - 1))
        dev = np.abs(d - dt)
        if dev.max() > jitter_tol * dt:
            i = int(np.argmax(dev))
            raise RecordingError(
                f"{src}: 'time' is not uniformly sampled: interval {i} -> {i + 1} is {d[i]:.6g} s, mean "
                f"dt is {dt:.6g} s (tolerance {jitter_tol:.3g} dt); resample the recording first"
            )
        if rate_hz is not None and abs(1.0 / dt - rate_hz) > rate_tol * rate_hz:
            raise RecordingError(
                f"{src}: 'time' gives a rate of {1.0 / dt:.6g} Hz, expected {rate_hz:.6g} Hz "
                f"(tolerance {rate_tol:.3g})"
            )
        kwargs: dict[str, Any] = {}
        if units is not None:
            kwargs["units"] = dict(units)
        return cls(
            name=name, gyr=gyr, acc=acc, mag=mag, dt=dt, quat=quat, motion=motion, frame=frame,
            source=source, extra=dict(extra or {}), meta=dict(meta or {}), **kwargs,
        )

    @property
    def n(self) -> int:
        """Number of samples."""
        return self.gyr.shape[0]

    @property
    def rate_hz(self) -> float:
        return 1.0 / self.dt

    @property
    def duration_s(self) -> float:
        return self.n * self.dt

    @property
    def time(self) -> np.ndarray:
        """Sample times, s, starting at 0."""
        return np.arange(self.n) * self.dt

    def slice(self, start: int, stop: int, name: str | None = None) -> Recording:
        """Samples ``start:stop`` as a new recording."""
        def cut(a):
            return None if a is None else a[start:stop]
        return replace(
            self,
            name=name or self.name,
            gyr=self.gyr[start:stop],
            acc=self.acc[start:stop],
            mag=cut(self.mag),
            quat=cut(self.quat),
            motion=self.motion[start:stop],
            extra={k: v[start:stop] for k, v in self.extra.items()},
        )

    def without_mag(self) -> Recording:
        return replace(self, mag=None)

    def __repr__(self) -> str:
        return (f"Recording({self.name!r}, n={self.n}, rate={self.rate_hz:.6g} Hz, frame={self.frame}, "
                f"mag={'yes' if self.mag is not None else 'no'}, truth={'yes' if self.quat is not None else 'no'})")
