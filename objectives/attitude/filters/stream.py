"""Filters on plain arrays and sample by sample.

:func:`as_recording` turns ``run(gyr, acc, mag, rate_hz=...)`` arguments into a validated
:class:`Recording`. A stream (``flt.stream(rate_hz=...)``) takes one sample at a time,
``s.update(gyr, acc, mag=None) -> q (4,)``, and returns the same quaternion as the batch
``flt.run(...)`` on the samples seen so far (tested sample by sample).

Two implementations:

:class:`StateStream`
    For filters whose kernel takes and returns its whole state (quaternion, bias, ...): each update
    calls the kernel on one sample, O(1) per sample. Subclasses implement ``_init_state`` and
    ``_step``.
:class:`BufferedStream` (fallback)
    For the others: keeps every sample and reruns the batch filter on all of them, returning the last
    row. Exact for causal filters by construction, but O(n) per update (O(n^2) in total), so it is
    meant for checks and short sessions, not for firmware-like loops. The first sample is run as a
    two-sample recording of the same sample (a :class:`Recording` needs two) and its first row is
    returned, which is the one-sample result of a causal filter.

Initialisation follows :func:`objectives.attitude.filters.base.initial_quaternion`: ``q0=None`` takes
the orientation from the first acc (and mag) sample; an explicit ``q0`` is in the filter's working
frame as with :meth:`AttitudeFilter.run`; ``"truth"`` is not available (no truth in a stream).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from objectives.attitude import fingerprint as _fingerprint
from objectives.attitude.data.recording import Recording

__all__ = ["as_recording", "resolve_dt", "StreamBase", "StateStream", "BufferedStream"]


def resolve_dt(owner: str, rate_hz: float | None, dt: float | None) -> float:
    """The sample time in s from exactly one of ``rate_hz`` (Hz) or ``dt`` (s); ValueError otherwise."""
    if (rate_hz is None) == (dt is None):
        raise ValueError(f"{owner}: give the sampling rate as exactly one of rate_hz= (Hz) or dt= (s), "
                         f"got rate_hz={rate_hz!r}, dt={dt!r}")
    key, v = ("rate_hz", rate_hz) if rate_hz is not None else ("dt", dt)
    ok = not isinstance(v, bool) and isinstance(v, (int, float, np.integer, np.floating))
    if not (ok and math.isfinite(v) and v > 0):
        raise ValueError(f"{owner}: {key} must be a finite number > 0, got {v!r}")
    return 1.0 / float(v) if key == "rate_hz" else float(v)


def as_recording(owner: str, data: Any, acc: Any = None, mag: Any = None, rate_hz: float | None = None,
                 dt: float | None = None, frame: str = "ENU") -> Recording:
    """``data`` itself when it is a :class:`Recording`, else a Recording of the arrays ``(gyr=data, acc,
    mag)`` sampled at ``rate_hz`` (or every ``dt`` s) with output in ``frame``.

    Raises
    ------
    ValueError
        Arrays together with a Recording, a missing ``acc``, a missing or doubled rate, wrong shapes
        (each array must be (N, 3) with the same N >= 2) or non-finite gyr/acc/mag samples.
    """
    if isinstance(data, Recording):
        extra = [k for k, v in (("acc", acc), ("mag", mag), ("rate_hz", rate_hz), ("dt", dt)) if v is not None]
        if extra:
            raise ValueError(f"{owner}: run(recording) takes no {extra} (they come from the recording)")
        return data
    if acc is None:
        raise ValueError(f"{owner}: run(gyr, acc, mag=None, rate_hz=...) needs acc, an (N, 3) array in m/s^2")
    from objectives.attitude.data.plausibility import warn_units

    step = resolve_dt(owner, rate_hz, dt)
    rec = Recording(name="arrays", gyr=data, acc=acc, mag=mag, dt=step, frame=frame, source=f"{owner}.run(arrays)")
    warn_units(f"{owner}.run", rec.gyr, rec.acc, stacklevel=4)
    return rec


#: a stream checks the units of its first sample and of its first this many samples
UNIT_CHECK_SAMPLES = 100


def _sample(owner: str, key: str, v: Any) -> np.ndarray:
    a = np.asarray(v, dtype=np.float64).reshape(-1) if v is not None else None
    if a is None or a.shape != (3,):
        raise ValueError(f"{owner}: update() needs {key} as a (3,) sample, got {v!r}")
    return a


class StreamBase:
    """What both stream kinds share: rate, frame, first-sample initialisation, input checks."""

    def __init__(self, flt: Any, rate_hz: float | None, dt: float | None, q0: Any, frame: str):
        from objectives.attitude.data.recording import FRAMES

        self.filter = flt
        self.dt = resolve_dt(flt.name, rate_hz, dt)
        _fingerprint.warn_filter(flt, dt=self.dt)  # the rate only: the sensor's statistics need samples
        if frame not in FRAMES:
            raise ValueError(f"{flt.name}: frame must be one of {FRAMES}, got {frame!r}")
        if isinstance(q0, str) and q0 == "truth":
            raise ValueError(f"{flt.name}: a stream has no truth to start from; give q0=None or a (4,) quaternion")
        self.frame = frame
        self.q0 = q0
        self.n = 0
        self.use_mag: bool | None = None
        self._unit_rows: list[tuple[np.ndarray, np.ndarray]] | None = []  # None once checked or warned

    def _read(self, gyr: Any, acc: Any, mag: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
        name = self.filter.name
        g, a = _sample(name, "gyr", gyr), _sample(name, "acc", acc)
        m = None if mag is None else _sample(name, "mag", mag)
        if self._unit_rows is not None:
            self._check_units(g, a)
        if self.use_mag is None:  # first sample: same decision as the batch run
            wants = bool(self.filter.values.get("use_mag", True))
            if self.filter.needs_mag and wants and m is None:  # mag=None: the IMU-only version, where there is one
                self.filter = self.filter.imu_only()
                wants = False
            self.use_mag = wants and m is not None
        elif self.use_mag and m is None:
            raise ValueError(f"{name}: this stream uses the magnetometer; every update needs mag=")
        return g, a, (m if self.use_mag else None)

    def _check_units(self, g: np.ndarray, a: np.ndarray) -> None:
        """The array API's unit check (:func:`~objectives.attitude.data.plausibility.warn_units`) on the first
        sample and on the first :data:`UNIT_CHECK_SAMPLES`; one warning at most per stream."""
        from objectives.attitude.data.plausibility import warn_units

        rows = self._unit_rows
        assert rows is not None
        rows.append((g.copy(), a.copy()))
        if len(rows) in (1, UNIT_CHECK_SAMPLES):
            warned = warn_units(f"{self.filter.name}.stream", np.array([r[0] for r in rows]),
                                np.array([r[1] for r in rows]), stacklevel=5)
            if warned or len(rows) == UNIT_CHECK_SAMPLES:
                self._unit_rows = None

    def _initial_q(self, acc: np.ndarray, mag: np.ndarray | None) -> np.ndarray:
        """The initial quaternion in the working frame (as ``initial_quaternion`` does)."""
        from objectives.attitude.filters.start import quat_from_acc_mag

        init = self.filter.values.get("init", "auto")
        q0 = self.q0 if init == "auto" else init
        if q0 is None or (isinstance(q0, str) and q0 == "accmag"):
            return quat_from_acc_mag(acc, mag, self.filter.working_frame)
        if isinstance(q0, str) and q0 == "broad":
            from objectives.attitude.init_broad import broad_start

            if mag is None:
                raise ValueError(f"{self.filter.name}: init broad needs a magnetometer sample in the first update")
            return broad_start(acc, np.asarray(mag, float).reshape(-1)[:3], self.filter.working_frame)
        q = np.asarray(q0, float).reshape(-1)
        if q.shape != (4,) or not np.all(np.isfinite(q)) or np.linalg.norm(q) == 0:
            raise ValueError(f"q0 must be 'accmag', 'broad' or a finite (4,) quaternion, got {q0!r}")
        return q / np.linalg.norm(q)


class StateStream(StreamBase):
    """O(1) stream over a kernel with state in/out (see module docstring).

    Subclasses implement ``_step(state, gyr, acc, mag) -> q (4,)`` with ``q`` in the working frame (or in
    ``output_frame`` when a subclass sets it); ``mag`` is (1, 3) or an empty (0, 3) array. The start state
    comes from the filter's ``kernel_setup`` (:meth:`_init_state`, with :meth:`_buffers` for a subclass's
    work arrays); a filter without one overrides ``_init_state(q0) -> state``.
    """

    output_frame: str | None = None

    def __init__(self, flt: Any, rate_hz: float | None, dt: float | None, q0: Any, frame: str):
        super().__init__(flt, rate_hz, dt, q0, frame)
        self.state: np.ndarray | None = None
        self._g = np.empty((1, 3))
        self._a = np.empty((1, 3))
        self._m = np.empty((1, 3))
        self._no_mag = np.empty((0, 3))

    def update(self, gyr: Any, acc: Any, mag: Any = None) -> np.ndarray:
        """Feed one sample (rad/s, m/s^2, any unit); the estimate after it, (4,) in ``frame``."""
        from objectives.attitude.quaternion import to_frame

        g, a, m = self._read(gyr, acc, mag)
        if self.state is None:
            self.state = self._init_state(self._initial_q(a, m))
        self._g[0] = g
        self._a[0] = a
        if m is not None:
            self._m[0] = m
        q = self._step(self.state, self._g, self._a, self._m if m is not None else self._no_mag)
        self.n += 1
        return to_frame(q[None, :], self.output_frame or self.filter.working_frame, self.frame)[0]

    def _init_state(self, q0: np.ndarray) -> np.ndarray:
        """The filter's ``kernel_setup`` at the stream's rate and magnetometer use: ``self._coef``, the setup's
        further start arrays ``self._extra`` (carried like the state) and the one-sample output ``self._out``
        set, the start state returned."""
        setup = self.filter.kernel_setup(self.dt, bool(self.use_mag), q0, self.frame)
        self._coef = setup.coef
        self._extra = setup.extra
        self._out = np.empty((1, 4))
        self._buffers()
        return setup.state

    def _buffers(self) -> None:
        """A subclass's work arrays and carried block states (none here)."""

    def _step(self, state: np.ndarray, gyr: np.ndarray, acc: np.ndarray, mag: np.ndarray) -> np.ndarray:
        raise NotImplementedError  # pragma: no cover - abstract


class BufferedStream(StreamBase):
    """Fallback stream: reruns the batch filter on every sample so far (O(n) per update)."""

    def __init__(self, flt: Any, rate_hz: float | None, dt: float | None, q0: Any, frame: str):
        super().__init__(flt, rate_hz, dt, q0, frame)
        self._gyr: list[np.ndarray] = []
        self._acc: list[np.ndarray] = []
        self._mag: list[np.ndarray] = []

    def update(self, gyr: Any, acc: Any, mag: Any = None) -> np.ndarray:
        """Feed one sample (rad/s, m/s^2, any unit); the estimate after it, (4,) in ``frame``."""
        g, a, m = self._read(gyr, acc, mag)
        self._gyr.append(g)
        self._acc.append(a)
        if m is not None:
            self._mag.append(m)
        self.n += 1
        rows = [0, 0] if self.n == 1 else slice(None)
        gyr_a = np.array(self._gyr)[rows]
        acc_a = np.array(self._acc)[rows]
        mag_a = np.array(self._mag)[rows] if self.use_mag else None
        rec = Recording(name="stream", gyr=gyr_a, acc=acc_a, mag=mag_a, dt=self.dt, frame=self.frame,
                        source=f"{self.filter.name}.stream()")
        quat = self.filter.run_detailed(rec, self.q0).quat
        return quat[0] if self.n == 1 else quat[-1]
