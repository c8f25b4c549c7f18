"""What every attitude filter shares: named parameters, default search space, initialisation, frames.

A filter is a numba batch kernel over whole arrays plus a thin subclass of :class:`AttitudeFilter`
that declares its parameters and calls the kernel. Subclasses set

- ``name``: the YAML name (``filter: madgwick``);
- ``decl``: the one :class:`objectives.params.ParamSet` declaring every parameter and option (default,
  search bounds, scale, unit, allowed values, doc, equation). ``params`` (the default search space as
  :class:`tuner.space.Real` entries) and ``defaults`` derive from it, and the values are validated once
  against it at construction (``_check`` is left for checks across parameters). A filter defined
  outside this package may instead set ``params`` and ``defaults`` by hand and validate in ``_check``;
- ``needs_mag``: whether the 9-D mode uses the magnetometer (a ``use_mag`` option switches 6-D);

and implement ``_run(rec, q0) -> FilterResult`` with ``q0`` already in the filter's working frame.
Output quaternions are sensor-to-earth ``(w, x, y, z)`` in the recording's frame (``rec.frame``).

A filter whose numba kernel takes a coefficient array and a start state builds both in one method,
:meth:`AttitudeFilter.kernel_setup` (a :class:`KernelSetup`, with a kernel's further start arrays in its
``extra``), which its serial ``_run``, its ``stream()`` and the population batch (:mod:`objectives.attitude.batch`)
all call (every filter with a numba kernel; VQF, which wraps an external package, is outside).

A class declares what it offers beyond running, each in its own namespace (a subclass, which may change
``_run``, declares its own): ``population``, the :class:`~objectives.attitude.batch.Population` that evaluates
candidates of the class in one numba kernel (``backend: threads``; None: serially only), and ``c_port``, the
:class:`~objectives.attitude.cexport.port.CPort` of its C99 version (None: no C export). Both live in the
filter's unit, beside its kernel; :func:`own` reads them.

Every filter runs on a :class:`Recording` or on plain arrays (``run(gyr, acc, mag, rate_hz=...)``) and
offers a per-sample :meth:`AttitudeFilter.stream`; see :mod:`objectives.attitude.filters.stream`.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, ClassVar

import numpy as np

from objectives.attitude import fingerprint as _fingerprint
from objectives.attitude.data.recording import Recording
from objectives.attitude.filters.start import initial_quaternion, quat_from_acc_mag, quat_from_rotmat
from objectives.params import Declared, Param, ParamSet
from tuner.space import Real, Space

__all__ = ["AttitudeFilter", "FilterResult", "KernelSetup", "G_SI", "INIT", "quat_from_rotmat", "quat_from_acc_mag",
           "initial_quaternion", "gravity_in_units", "own"]

#: the start option every declared filter gets (YAML ``init: broad`` in ``fixed`` or a ``--params`` file)
INIT = Param("init", "auto", choices=("auto", "accmag", "truth", "broad"),
             doc="initial orientation: auto (the run's q0, objective.q0: accmag by default), accmag (first "
                 "acc/mag sample), truth (first finite truth sample) or broad (BROAD's quatFromAccMag, "
                 "as in its published results)")


#: standard gravity, m/s^2: ``g_ref`` of :meth:`AttitudeFilter.kernel_setup` for an accelerometer in m/s^2
G_SI = 9.80665


def gravity_in_units(rec: Recording) -> float:
    """Standard gravity in the recording's accelerometer unit (``m/s^2`` or ``g``); else the median
    ``|acc|`` of the recording (a recording at rest most of the time reads g): the ``g_ref`` a kernel that
    compares ``|acc|`` with g gets from :meth:`AttitudeFilter.kernel_setup`."""
    unit = str(rec.units.get("acc", "")).replace(" ", "").lower()
    if unit in ("m/s^2", "m/s2", "m/s**2", "ms^-2"):
        return G_SI
    if unit == "g":
        return 1.0
    return float(np.median(np.linalg.norm(rec.acc, axis=1)))


def own(cls: type, attr: str) -> Any:
    """``cls``'s own ``attr`` (``population``, ``c_port``), not one inherited: a subclass may change what its
    kernel computes, so it offers a population kernel or a C port only by declaring its own."""
    return vars(cls).get(attr)


@dataclass(frozen=True)
class KernelSetup:
    """What a filter's numba kernel starts from on one recording (:meth:`AttitudeFilter.kernel_setup`).

    coef : (k,) the kernel's coefficient array (its layout: the kernel's docstring).
    state : (m,) the kernel's state before the first sample: the start orientation in the kernel's own
        form (quaternion, ZYX Euler angles or tilt angle), then what the kernel carries from sample to
        sample (bias, covariance, the robust blocks' states).
    extra : the further arrays of a kernel that starts from more than one state array, in the order its
        docstring gives (the UKFs: the integer state, then with a robust block on the blocks' coefficients
        and states; :meth:`objectives.attitude.filters.ukf.QUKF.kernel_setup`); empty for the others.
    """

    coef: np.ndarray
    state: np.ndarray
    extra: tuple[np.ndarray, ...] = ()


@dataclass(frozen=True)
class FilterResult:
    """Output of a filter run.

    quat : (N, 4) sensor-to-earth estimates in ``frame``; non-finite rows mark samples where the
        filter diverged (metrics count them as maximal errors).
    diagnostics : named (N,) or (N, k) signals for reports (fuzzy scaling factor, disturbance
        measures, innovation, estimated gyro bias, ...).
    """

    quat: np.ndarray
    frame: str
    diagnostics: Mapping[str, np.ndarray] = field(default_factory=dict)


class AttitudeFilter(Declared):
    """Base class of all attitude filters (see module docstring)."""

    name: ClassVar[str] = ""
    #: the one declaration of the parameters (``params`` and ``defaults`` derive from it)
    decl: ClassVar[ParamSet | None] = None
    params: ClassVar[tuple[Real, ...]] = ()
    defaults: ClassVar[dict[str, Any]] = {}
    #: earth frame the kernel works in; the output is converted to the recording's frame
    working_frame: ClassVar[str] = "ENU"
    needs_mag: ClassVar[bool] = False
    #: the population kernel that runs this class (:class:`objectives.attitude.batch.Population`; None: serial
    #: only); read from the class's own namespace (:func:`own`), so a subclass declares its own
    population: ClassVar[Any] = None
    #: the C port (:class:`objectives.attitude.cexport.port.CPort`; None: none); read as ``population``
    c_port: ClassVar[Any] = None

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        if cls.__dict__.get("decl") is not None:
            if "init" not in cls.decl.names():  # every declared filter takes the start option
                cls.decl = ParamSet(cls.decl.owner, cls.decl.params + (INIT,))
            cls.params = cls.decl.reals()
            cls.defaults = cls.decl.defaults()

    def __init__(self, **values: Any):
        if self.decl is not None:
            self.values: dict[str, Any] = self.decl.validate(values)
        else:
            unknown = sorted(set(values) - set(self.defaults))
            if unknown:
                raise ValueError(
                    f"{self.name}: unknown parameter(s) {unknown}; known: {sorted(self.defaults)}"
                )
            self.values = {**self.defaults, **values}
        self._check()

    def _check(self) -> None:
        """Checks across parameters (each value alone is checked against ``decl``); ValueError."""

    # --- declaration ------------------------------------------------------------------------
    @classmethod
    def _describe_extra(cls) -> dict[str, Any]:
        return {"working_frame": cls.working_frame, "needs_mag": cls.needs_mag}

    # --- search space -----------------------------------------------------------------------
    @classmethod
    def space(cls) -> Space:
        """Default search space: bounded parameters searched, options fixed at their defaults."""
        return Space(cls.params)

    @classmethod
    def from_run(cls, run_dir: str | Path, **overrides: Any) -> AttitudeFilter:
        """The deployed filter of a finished run: every value the run tuned, fixed or relied on as default
        (:func:`tuner.deployment.load_deployment`), ``overrides`` applied.

        Called on :class:`AttitudeFilter` itself it builds the run's filter class; on a subclass, a run
        of another filter is a ``ValueError``. Settings that only served scoring are not part of it: a run
        scored from the ground-truth start gives a filter that starts from the first acc/mag sample, so
        ``from_run(run).run(gyr, acc, mag, rate_hz=...)`` works on live data.
        """
        from tuner.deployment import load_deployment

        dep = load_deployment(run_dir)
        if dep.kind != "filter":
            raise ValueError(f"{run_dir}: the run tuned a {dep.kind} objective ({dep.name!r}), not a filter")
        target = cls
        if cls is AttitudeFilter or not cls.name:
            from objectives.attitude.filters.registry import get_filter

            target = get_filter(dep.name)
        elif dep.name and dep.name != cls.name:
            raise ValueError(f"{run_dir}: the run tuned filter {dep.name!r}; use {dep.name}'s class "
                             f"(or AttitudeFilter.from_run), not {cls.__name__}")
        unknown = sorted(set(dep.values) - set(target.defaults))
        if unknown:  # a value the filter would drop: the filter built would not be the one recorded
            raise ValueError(f"{run_dir}: deployment.values.{unknown[0]}: not a parameter of {target.name}; "
                             f"allowed: {', '.join(sorted(target.defaults))}")
        flt = target(**{**dep.values, **overrides})
        flt.tuned_on = _fingerprint.stored(run_dir)  # new data is compared with it (run(), stream())
        return flt

    # --- running ----------------------------------------------------------------------------
    def run(self, data: Recording | Any, acc: Any = None, mag: Any = None, *, rate_hz: float | None = None,
            dt: float | None = None, q0: Any = None, frame: str = "ENU", disturbances: Any = None) -> np.ndarray:
        """Estimate orientation over a whole recording or over plain arrays.

        Parameters
        ----------
        data : Recording or (N, 3) array
            A :class:`Recording`, or the gyroscope samples in rad/s.
        acc, mag : (N, 3) arrays
            With arrays: accelerometer (m/s^2) and optional magnetometer (any unit) samples.
        rate_hz, dt : float
            With arrays: the sampling rate in Hz or the sample time in s (exactly one).
        q0 : None, "accmag", "truth", "broad" or (4,)
            Initialisation (see :func:`initial_quaternion`); the filter's ``init`` option, unless
            ``auto``, takes precedence.
        frame : {"ENU", "NED"}
            With arrays: earth frame of the output.
        disturbances : optional
            Precomputed inputs of adaptive filters (see :meth:`run_detailed`).

        Returns
        -------
        (N, 4) sensor-to-earth quaternions ``(w, x, y, z)`` in ``rec.frame`` (``frame`` for arrays).
        """
        from objectives.attitude.filters.stream import as_recording

        rec = as_recording(self.name, data, acc, mag, rate_hz, dt, frame)
        _fingerprint.warn_filter(self, rec)
        flt = self.imu_only() if not isinstance(data, Recording) and mag is None else self
        return flt.run_detailed(rec, q0, disturbances).quat

    def imu_only(self) -> AttitudeFilter:
        """This filter without the magnetometer (``use_mag=False``): what ``run(gyr, acc, mag=None)`` and a
        stream fed without ``mag`` use. ValueError for a filter that needs one (no ``use_mag`` option)."""
        if not self.needs_mag or not self.values.get("use_mag", True):
            return self
        if "use_mag" not in self.values:
            raise ValueError(f"{self.name}: needs a magnetometer (no IMU-only version): pass mag= as an (N, 3) array")
        other = type(self)(**{**self.values, "use_mag": False})
        other.tuned_on = getattr(self, "tuned_on", None)
        return other

    def stream(self, rate_hz: float | None = None, dt: float | None = None, q0: Any = None,
               frame: str = "ENU") -> Any:
        """A per-sample filter: ``s.update(gyr, acc, mag=None) -> q (4,)``, equal to :meth:`run`.

        Filters whose kernel takes and returns its state update in O(1) per sample; the others use a
        documented fallback (see :mod:`objectives.attitude.filters.stream`).
        """
        from objectives.attitude.filters.stream import BufferedStream

        return BufferedStream(self, rate_hz, dt, q0, frame)

    def run_detailed(self, rec: Recording, q0: Any = None, disturbances: Any = None) -> FilterResult:
        """As :meth:`run`, with the filter's diagnostics.

        ``disturbances`` passes precomputed fuzzy inputs of adaptive filters (the value their
        ``disturbances(rec)`` method returns); they depend only on fixed window options, so an
        objective computes them once per recording instead of once per evaluation.
        """
        self._given_disturbances = disturbances
        try:
            return self._run_detailed(rec, q0)
        finally:
            self._given_disturbances = None

    def _disturbances(self, rec: Recording) -> Any:
        """The disturbances given to :meth:`run_detailed`, else ``self.disturbances(rec)``."""
        given = getattr(self, "_given_disturbances", None)
        return given if given is not None else self.disturbances(rec)

    def _run_detailed(self, rec: Recording, q0: Any = None) -> FilterResult:
        from objectives.attitude.quaternion import to_frame

        if self.needs_mag and self.values.get("use_mag", True) and rec.mag is None:
            raise ValueError(f"{self.name}: recording {rec.name!r} has no magnetometer; set use_mag: false")
        use_mag = bool(self.values.get("use_mag", True)) and rec.mag is not None
        init = self.values.get("init", "auto")
        qi = initial_quaternion(rec, self.working_frame, q0 if init == "auto" else init, use_mag=use_mag)
        res = self._run(rec, qi)
        if res.frame != rec.frame:
            res = FilterResult(to_frame(res.quat, res.frame, rec.frame), rec.frame, res.diagnostics)
        return res

    def _run(self, rec: Recording, q0: np.ndarray) -> FilterResult:  # pragma: no cover - abstract
        raise NotImplementedError

    def kernel_setup(self, dt: float, use_mag: bool, q0: np.ndarray, frame: str, g_ref: float = G_SI) -> KernelSetup:
        """The coefficient array and start state of this filter's kernel on a recording: the one place the
        serial run, the stream and the population batch get them.

        Parameters
        ----------
        dt : float
            Sample time, s.
        use_mag : bool
            The run uses the magnetometer (the filter's ``use_mag`` and a magnetometer present).
        q0 : (4,) array
            Start quaternion, sensor-to-earth in the filter's working frame.
        frame : str
            The recording's earth frame (the 1-D filters' tilt angle follows its convention).
        g_ref : float
            Standard gravity in the accelerometer's unit (:func:`gravity_in_units`);
            :data:`G_SI` for m/s^2, as :meth:`run` on arrays and :meth:`stream` take it.

        Filters without such a kernel raise ``NotImplementedError``.
        """
        raise NotImplementedError(f"{self.name}: no kernel with a coefficient array and a start state")

    def __repr__(self) -> str:
        args = ", ".join(f"{k}={v!r}" for k, v in self.values.items())
        return f"{type(self).__name__}({args})"
