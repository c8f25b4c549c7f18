"""Mahony's and Madgwick's sample code on the tilt bench, reduced to rotations about y (thesis 3.1.5, Tables
3.4-3.5); see :mod:`objectives.attitude.filters.kf1d` for the equations and the integration option."""

from __future__ import annotations

from typing import Any, ClassVar

import numpy as np

from objectives.attitude.data.recording import Recording
from objectives.attitude.filters.base import G_SI, AttitudeFilter, FilterResult, KernelSetup
from objectives.attitude.filters.kf1d.kernel import MADGWICK_C, MAHONY_C, madgwick1d_kernel, mahony1d_kernel
from objectives.attitude.filters.kf1d.tilt import (
    TiltStream,
    quat_from_tilt,
    tilt_from_quat,
    tilt_inputs,
    tilt_start,
    up_sign,
)
from objectives.params import NONNEG, Param, ParamSet

__all__ = ["Mahony1D", "Madgwick1D"]


_EXACT = Param("exact_step", True, choices=(True, False),
               doc="exact rotation per sample (true) or the sample code's first-order step (false)")


class Mahony1D(AttitudeFilter):
    """Mahony's filter (sample code) on the tilt bench, reduced to rotations about y (thesis 3.1.5.1).

    Parameters
    ----------
    Kp : float
        Proportional gain, rad/s per unit error (the sample code's ``twoKp / 2``).
    Ki : float
        Integral gain, rad/s^2 per unit error; 0 disables the integral (thesis initial value).
    exact_step : bool, fixed
        See the module docstring.

    Defaults: the thesis's initial values (Kp 0.5, Ki 0). Search space: both runs of Table 3.4,
    Kp in [0.125, 0.7], Ki in [0, 0.005]. Thesis optimum (second run): Kp 0.2613, Ki about 9e-5
    (partly unreadable), F = 1.7849 deg^2.

    Diagnostics: ``angle`` (N,) rad, ``gyr_bias`` (N,) rad/s (minus the integral term).
    """

    name: ClassVar[str] = "mahony1d"
    decl: ClassVar[ParamSet] = ParamSet("mahony1d", (
        Param("Kp", 0.5, (0.125, 0.7), unit="rad/s", doc="proportional gain (Table 3.4)", eq="Table 3.4",
              allowed=NONNEG),
        Param("Ki", 0.0, (0.0, 0.005), unit="rad/s^2", doc="integral gain (Table 3.4)", eq="Table 3.4",
              allowed=NONNEG),
        _EXACT,
    ))

    def _run(self, rec: Recording, q0: np.ndarray) -> FilterResult:
        gy, ax, az = tilt_inputs(rec)
        th = np.empty(rec.n)
        b = np.empty(rec.n)
        setup = self.kernel_setup(rec.dt, False, q0, rec.frame)
        th[0], b[0] = tilt_from_quat(q0, rec.frame, self.working_frame), 0.0
        self._pair_step(setup.state, gy, ax, az, up_sign(rec.frame), setup.coef, th, b)
        return FilterResult(quat_from_tilt(th), rec.frame, {"angle": th, "gyr_bias": b})

    def kernel_setup(self, dt: float, use_mag: bool, q0: np.ndarray, frame: str, g_ref: float = G_SI) -> KernelSetup:
        """The kernel's gains ``(Ts, Kp, Ki)`` (layout ``MAHONY_C``; it takes them as scalars) and start state
        (:func:`~.tilt.tilt_start`); ``use_mag`` and ``g_ref`` do not enter."""
        return KernelSetup(MAHONY_C.pack(DT=dt, KP=self.values["Kp"], KI=self.values["Ki"]),
                           tilt_start(q0, frame, self.working_frame))

    def stream(self, rate_hz: float | None = None, dt: float | None = None, q0: Any = None, frame: str = "ENU"):
        """O(1) per-sample filter (the kernel carries the quaternion and integral in ``state``)."""
        return TiltStream(self, rate_hz, dt, q0, frame)

    def _pair_step(self, state, gy, ax, az, up, coef, th, b) -> None:
        """The kernel on ``gy, ax, az`` from ``state`` (the run's arrays or the stream's (previous, current) pair)."""
        mahony1d_kernel(gy, ax, az, up, coef[MAHONY_C.KP], coef[MAHONY_C.KI], coef[MAHONY_C.DT], state,
                        bool(self.values["exact_step"]), th, b)


class Madgwick1D(AttitudeFilter):
    """Madgwick's filter (sample code) on the tilt bench, reduced to rotations about y (thesis 3.1.5.2).

    Parameters
    ----------
    beta : float
        Gradient-descent gain, rad/s (thesis initial 0.1; optimum 0.0387, Table 3.5).
    exact_step : bool, fixed
        See the module docstring.

    Search space: both runs of Table 3.5, beta in [0.01, 0.15].
    Diagnostics: ``angle`` (N,) rad.
    """

    name: ClassVar[str] = "madgwick1d"
    decl: ClassVar[ParamSet] = ParamSet("madgwick1d", (
        Param("beta", 0.1, (0.01, 0.15), "log", "rad/s", "gradient step gain (Table 3.5)", "Table 3.5", NONNEG),
        _EXACT,
    ))

    def _run(self, rec: Recording, q0: np.ndarray) -> FilterResult:
        gy, ax, az = tilt_inputs(rec)
        th = np.empty(rec.n)
        setup = self.kernel_setup(rec.dt, False, q0, rec.frame)
        th[0] = tilt_from_quat(q0, rec.frame, self.working_frame)
        self._pair_step(setup.state, gy, ax, az, up_sign(rec.frame), setup.coef, th, None)
        return FilterResult(quat_from_tilt(th), rec.frame, {"angle": th})

    def kernel_setup(self, dt: float, use_mag: bool, q0: np.ndarray, frame: str, g_ref: float = G_SI) -> KernelSetup:
        """The kernel's gains ``(Ts, beta)`` (layout ``MADGWICK_C``; it takes them as scalars) and start state
        (:func:`~.tilt.tilt_start`); ``use_mag`` and ``g_ref`` do not enter."""
        return KernelSetup(MADGWICK_C.pack(DT=dt, BETA=self.values["beta"]), tilt_start(q0, frame, self.working_frame))

    stream = Mahony1D.stream

    def _pair_step(self, state, gy, ax, az, up, coef, th, b) -> None:
        """The kernel on ``gy, ax, az`` from ``state`` (no bias output: ``b`` unused)."""
        madgwick1d_kernel(gy, ax, az, up, coef[MADGWICK_C.BETA], coef[MADGWICK_C.DT], state,
                          bool(self.values["exact_step"]), th)
