"""``realtime``: a causal attitude filter of this project built on VQF's design.

Design from D. Laidig and T. Seel, "VQF: Highly accurate IMU orientation estimation with bias estimation and
magnetic disturbance rejection", Information Fusion 91:187-204 (2023), written as a numba kernel of its own
(:mod:`objectives.attitude.filters.realtime.kernel`) so that it can be tuned, batched and exported like the
project's other filters:

- **inclination and heading corrected apart**: the gyroscope is integrated (strapdown), the accelerometer,
  rotated into that almost inertial frame and low-passed there (second-order, time constant ``tau_acc_s``),
  corrects only the inclination, and the magnetometer only the heading offset ``delta`` (first-order,
  ``tau_mag_s``), so a disturbed field can never tilt the estimate;
- **gyro bias in motion and at rest** (``motion_bias``, ``rest_bias``): a 3-state Kalman filter whose
  measurement in motion is the inclination correction rate (through the low-passed rotation matrix) and at
  rest the low-passed gyroscope; rest is ``rest_min_s`` of gyroscope and accelerometer within
  ``rest_th_gyr_dps`` and ``rest_th_acc`` of their ``rest_filter_tau_s`` low-pass;
- **magnetic disturbance rejection** (``mag_rejection``): the field's norm and dip in the earth frame are
  compared with a learned reference (``mag_norm_th``, ``mag_dip_th_deg``); while disturbed the heading is
  not corrected for at most ``mag_max_rejection_s``, then with ``tau_mag_s`` times ``mag_rejection_factor``;
  a new homogeneous field is accepted after ``mag_new_s`` of rotation in it, which re-converges the heading.

Every tuning parameter is a time constant in s or a threshold in physical units; the per-sample gains are
derived from the sample time, so values tuned at one rate hold at another. Each block is an option (all on by
default, VQF's defaults); ``start: q0`` starts the strapdown quaternion from the run's initial orientation
(the common ``init``, an acc/mag sample by default) instead of the identity with VQF's averaging start.

Output: sensor-to-earth ``(w, x, y, z)`` in ENU (9-D with magnetometer, else 6-D with arbitrary heading).
Diagnostics: ``bias`` (N, 3) rad/s, ``rest`` (N,), ``mag_dist`` (N,), ``delta`` (N,) rad.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from objectives.attitude.cexport.port import CMember, CPort
from objectives.attitude.data.recording import Recording
from objectives.attitude.filters.base import G_SI, AttitudeFilter, FilterResult, KernelSetup
from objectives.attitude.filters.layout import Layout
from objectives.attitude.filters.realtime.coefficients import LOW_PASSES, C, S, coefficients, initial_state
from objectives.attitude.filters.realtime.kernel import realtime_kernel
from objectives.attitude.filters.stream import StateStream
from objectives.params import NONNEG, POSITIVE, Interval, Param, ParamSet

__all__ = ["Realtime", "DECL"]

_REF = "Laidig & Seel 2023"

#: the one declaration (defaults are VQF's published defaults, in the same units)
DECL = ParamSet("realtime", (
    Param("tau_acc_s", 3.0, (0.3, 30.0), "log", "s", "time constant of the inclination correction "
          "(second-order low-pass of the earth-frame accelerometer)", _REF, POSITIVE),
    Param("tau_mag_s", 9.0, (1.0, 100.0), "log", "s", "time constant of the heading correction", _REF, POSITIVE),
    Param("use_mag", True, doc="9-D (true) or 6-D (false) fusion"),
    Param("motion_bias", True, doc="estimate the gyro bias in motion (from the inclination correction)"),
    Param("rest_bias", True, doc="estimate the gyro bias at rest (rest detection)"),
    Param("mag_rejection", True, doc="magnetic disturbance detection and rejection"),
    Param("start", "self", choices=("self", "q0"),
          doc="self: identity start with averaging low-passes and fast heading convergence; q0: strapdown "
              "start at the run's initial orientation"),
    Param("bias_sigma_init_dps", 0.5, unit="deg/s", doc="initial bias uncertainty", allowed=POSITIVE),
    Param("bias_forgetting_s", 100.0, unit="s", doc="time in which the bias variance grows by (0.1 deg/s)^2",
          allowed=POSITIVE),
    Param("bias_clip_dps", 2.0, unit="deg/s", doc="largest bias and bias residual", allowed=POSITIVE),
    Param("bias_sigma_motion_dps", 0.1, unit="deg/s", doc="std of the bias measurement in motion",
          allowed=POSITIVE),
    Param("bias_vertical_forgetting", 1e-4, unit="1", doc="weight of the vertical bias component in motion",
          allowed=NONNEG),
    Param("bias_sigma_rest_dps", 0.03, unit="deg/s", doc="std of the bias measurement at rest", allowed=POSITIVE),
    Param("rest_min_s", 1.5, unit="s", doc="time at rest before rest is detected", allowed=NONNEG),
    Param("rest_filter_tau_s", 0.5, unit="s", doc="low-pass time constant of the rest detection",
          allowed=POSITIVE),
    Param("rest_th_gyr_dps", 2.0, unit="deg/s", doc="gyro deviation threshold of rest", allowed=POSITIVE),
    Param("rest_th_acc", 0.5, unit="m/s^2", doc="accelerometer deviation threshold of rest", allowed=POSITIVE),
    Param("mag_current_tau_s", 0.05, unit="s", doc="low-pass of the field norm and dip (0: none)", allowed=NONNEG),
    Param("mag_ref_tau_s", 20.0, unit="s", doc="time constant of the learned field reference", allowed=NONNEG),
    Param("mag_norm_th", 0.1, unit="1", doc="relative norm deviation that counts as disturbed", allowed=POSITIVE),
    Param("mag_dip_th_deg", 10.0, unit="deg", doc="dip deviation that counts as disturbed", allowed=POSITIVE),
    Param("mag_new_s", 20.0, unit="s", doc="time of rotation in a new field before it is accepted",
          allowed=NONNEG),
    Param("mag_new_first_s", 5.0, unit="s", doc="the same for the first field", allowed=NONNEG),
    Param("mag_new_min_gyr_dps", 20.0, unit="deg/s", doc="rotation rate that counts for mag_new_s",
          allowed=NONNEG),
    Param("mag_min_undisturbed_s", 0.5, unit="s", doc="time undisturbed before the heading is corrected again",
          allowed=NONNEG),
    Param("mag_max_rejection_s", 60.0, unit="s", doc="longest rejection of a disturbed field", allowed=NONNEG),
    Param("mag_rejection_factor", 2.0, (1.0, 10.0), "log", "1",
          "tau_mag_s multiplier after the rejection time; recovery speed of the rejection budget", _REF,
          Interval(1.0)),
    Param("mag_first_at_rest", False, doc="accept the first field after mag_new_first_s of stable norm and dip "
          "also while at rest (the rest detector's rest, with or without rest_bias; VQF: only while rotating "
          "faster than mag_new_min_gyr_dps, which still counts); never at rest nor rotating that fast, no field "
          "is accepted: the heading keeps its fast start and the gyro, and after mag_max_rejection_s follows the "
          "field at 1/mag_rejection_factor of its gain"),
    Param("mag_recover_tau_s", 0.0, (1.0, 60.0), "log", "s", "heading time constant while the rejection budget "
          "recovers after a disturbance (fast re-convergence; 0: tau_mag_s)", allowed=NONNEG),
))


#: the C port's start phase of each low-pass of the state (the kernel marks a low-pass not yet started by NaN)
LP = Layout("LP", tuple((name, 1, f"phase of the low-pass S_{name}") for name in LOW_PASSES))
#: the C port (port.c, ported from kernel.py with the layouts of coefficients.py; sine and cosine of the shared
#: parts): the params are every value of DECL in its units, the C derives the per-sample coefficients as the kernel
C_PORT = CPort((__package__, "port.c"), ("trig.c",), (
    CMember("real", "c", (C.LEN,), "per-sample coefficients at dt_s (layout C of kernel.py)"),
    CMember("real", "s", (S.LEN,), "the state carried between samples (layout S)"),
    CMember("int", "lpf", (LP.LEN,), "phase of each low-pass: 0 no sample, 1 averaging its first tau, 2 running"),
    CMember("real", "dt_s"),
    CMember("int", "started", (), "0: start orientation from the next sample (start q0)"),
    CMember("params", "p")), layouts=(C, S, LP))


class Realtime(AttitudeFilter):
    """Causal attitude filter on VQF's design with the project's magnetic-field additions (module docstring).

    Searched by default: ``tau_acc_s``, ``tau_mag_s``, ``mag_rejection_factor``, ``mag_recover_tau_s``
    (default 0, off: on the lower bound for a prior). Raises ``ValueError`` for values outside their
    declared ranges (at construction) and for a non-positive sample time.
    """

    name = "realtime"
    working_frame = "ENU"
    needs_mag = True
    decl = DECL
    c_port = C_PORT

    def kernel_setup(self, dt: float, use_mag: bool, q0: np.ndarray, frame: str, g_ref: float = G_SI) -> KernelSetup:
        """The kernel's coefficient array at sample time ``dt`` s (:func:`coefficients`) and its start state
        (:func:`initial_state`: the strapdown quaternion starts at ``q0`` with ``start: q0``, else at the
        identity); ``frame`` and ``g_ref`` do not enter (ENU, unit vectors). ValueError for a non-positive ``dt``.
        """
        if not (np.isfinite(dt) and dt > 0):
            raise ValueError(f"realtime: dt must be a positive number of seconds, got {dt!r}")
        c = coefficients(self.values, float(dt), use_mag)
        return KernelSetup(c, initial_state(c, q0 if self.values["start"] == "q0" else None))

    def _run(self, rec: Recording, q0: np.ndarray) -> FilterResult:
        use_mag = bool(self.values["use_mag"]) and rec.mag is not None
        setup = self.kernel_setup(rec.dt, use_mag, q0, rec.frame)
        c, s = setup.coef, setup.state
        n = rec.gyr.shape[0]
        out = np.empty((n, 4))
        bias = np.empty((n, 3))
        flags = np.empty((n, 3))
        mag = np.ascontiguousarray(rec.mag, dtype=np.float64) if use_mag else np.zeros((0, 3))
        realtime_kernel(np.ascontiguousarray(rec.gyr, dtype=np.float64),
                        np.ascontiguousarray(rec.acc, dtype=np.float64), mag, c, s, out, bias, flags)
        diag: dict[str, Any] = {"bias": bias, "rest": flags[:, 0] != 0.0}
        if use_mag:
            diag["mag_dist"] = flags[:, 1] != 0.0
            diag["delta"] = flags[:, 2]
        return FilterResult(out, "ENU", diag)

    def stream(self, rate_hz: float | None = None, dt: float | None = None, q0: Any = None, frame: str = "ENU"):
        """O(1) per-sample filter: the kernel on one sample at a time with its state carried (equal to
        :meth:`run` on the samples seen so far)."""
        return _RealtimeStream(self, rate_hz, dt, q0, frame)


class _RealtimeStream(StateStream):
    def _buffers(self) -> None:
        self._bias = np.empty((1, 3))
        self._flags = np.empty((1, 3))

    def _step(self, state, gyr, acc, mag):
        realtime_kernel(gyr, acc, mag, self._coef, state, self._out, self._bias, self._flags)
        return self._out[0]
