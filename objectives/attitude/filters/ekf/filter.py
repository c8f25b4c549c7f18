"""Quaternion EKF with TRIAD measurement and its fuzzy-adaptive variant (FAEKF).

Source: Odry et al. 2020, "A Novel Fuzzy-Adaptive Extended Kalman Filter for Real-Time Attitude
Estimation of Mobile Robots", Sensors 20, 803 (``/work/shared/seeds/faekf-odry-2020-sensors.txt``).

The EKF (section 3.3)
---------------------
State ``x = (q0, q1, q2, q3, bx, by, bz)``: the sensor-to-earth quaternion and the gyro bias (rad/s).
Time update (eqs. 16, 20, 21): ``q_k = q_{k-1} + Ts/2 * q_{k-1} (x) (0, Omega_{k-1} - b_{k-1})``,
``b_k = b_{k-1}``, ``P^- = Phi P Phi^T + Q``. Measurement (eqs. 11-15, 17, 22): the TRIAD quaternion
from accelerometer and magnetometer, ``z = q_TRIAD = [I4 0] x + v``. Noise (eq. 36):
``Q = diag(q_q I4, q_w I3)``, ``R = rho I4``.

Units and rate: like the paper, ``q_q`` (quaternion units^2 per sample), ``q_w`` ((rad/s)^2 per
sample) and ``rho`` (quaternion units^2) are **per-sample** variances; the paper's values
(``q_q = 1.45e-6``, ``q_w = 9.71e-10``, ``rho = 3.53``, section 5.2) assume ``f_s = 1 kHz``. They are
used as given at any rate (a 100 Hz recording needs its own tuning).

The FAEKF (section 4)
---------------------
``R_k = K_k R`` (eq. 31) where ``K_k`` is the output of a zero-order Sugeno system with min-AND
(eqs. 28-30) over three inputs: the vibration frequency ``f`` (Hz, eqs. 23-25), the accumulated
external acceleration ``a_ext`` (g, eq. 26) and magnetic perturbation ``h_ext`` (normalised units,
eq. 27), each covered by three Gaussian sets Z, S, B; the 27 rules of Table 1 map the set indices
``(i_f, i_a, i_h)`` in {0, 1, 2} to the singleton ``K_{1 + i_f + i_a + i_h}``. The disturbance
measures depend only on fixed window options, so :meth:`FAEKF.disturbances` computes them once and
``FAEKF.run_detailed(rec, disturbances=...)`` reuses them.

Deviations from the paper (and why)
-----------------------------------
- Working frame NED as in the paper (``working_frame = "NED"``); the output is converted to the
  recording's frame. Our accelerometer convention (specific force: +g along *up* at rest) is used with
  the reference ``s1 = up = (0, 0, -1)`` in NED; the paper's ``g = (0, 0, 9.81)`` with the opposite
  sign convention gives the same TRIAD matrix. The magnetic reference enters TRIAD only through its
  horizontal direction (north), so the inclination is not a parameter.
- The Jacobian is the exact derivative of eq. 16. The text of eq. 21 (as converted) has rows 2-4 of
  the quaternion block permuted/sign-flipped with respect to eq. 16; its bias columns agree with ours.
- Eq. 14 divides by ``4 q0`` and fails near 180 deg; we use Shepperd's four-branch extraction (equal
  to eq. 14 when ``1 + tr R`` is the largest pivot) and flip the sign of ``z`` into the hemisphere of
  the prior ``q^-`` (``q`` and ``-q`` are the same attitude; the paper's linear measurement model
  needs them on the same side).
- The time update integrates the gyro exactly by default, ``q_k = q_{k-1} (x) exp(omega Ts / 2)``
  (option ``integration = "exact"``); ``integration = "euler"`` is eq. 16 literally. Both use
  ``Phi`` with the quaternion block of the chosen step (linear in ``q``) and the bias columns of
  eq. 21. They differ by ``(|omega| Ts)^3 / 12`` rad per sample: nothing at rest, but 10 mrad/s of
  drift at the bench's 50 rad/s (``Ts`` = 1 ms), and only the exact step tracks noise-free data to
  rounding.
- The quaternion is normalised after each measurement update (the first-order step of eq. 16 grows
  the norm by ``(|omega| Ts)^2 / 4`` per sample, 6e-4 at 50 rad/s and 1 kHz).
- Without magnetometer (``use_mag = 0``) the second TRIAD vector is the predicted north direction in
  the sensor frame, ``R(q^-)^T e_N``: the accelerometer corrects tilt and the heading follows the gyro.
- Sample ``i`` uses gyro sample ``i - 1`` to propagate from ``i - 1`` to ``i`` (eq. 16 indexing), then
  the TRIAD of sample ``i``; sample 0 is the initial state.
- The covariance update ``P = (I - G H) P^-`` is computed in the algebraically equal symmetric form
  ``P = P^- - W^T W`` with ``W = L^{-1} P^-_{q,:}``, ``L L^T = P^-_qq + R_k`` (Cholesky of a 4x4).
- Options for real recordings (defaults keep the paper's filter; ``configs/broad_ekf.yaml`` sets
  them). On BROAD (285.7 Hz) the paper's filter was worse than a Madgwick filter (tuned train mean
  9.6 vs 5.4 deg), for three reasons found there:

  * ``gyro_sample``: the gyro sample that propagates ``k-1 -> k``. ``"previous"`` (eq. 16, and the
    synthetic recordings, whose ``gyr[k]`` is the rate over ``[t_k, t_k+1]``) or ``"current"``
    (BROAD and its reference filters: ``gyr[k]`` covers ``(t_{k-1}, t_k]``). The wrong one lags the
    gyro one sample, 4 deg at BROAD's 20 rad/s rotations.
  * ``p0_b``: the default ``1e-6 (rad/s)^2`` (0.057 deg/s) froze the bias state on MEMS gyros whose
    biases reach 0.5 deg/s (BROAD); with a slow TRIAD correction the attitude then lags by
    ``bias x time constant`` (3 deg at rest after 20 s). Real data needs ``p0_b ~ 1e-4``.
  * ``acc_gate``, ``huber_deg``: the measurement ``z - q`` of eq. 17 is largest for a TRIAD 180 deg
    away, and the hemisphere of ``z`` is chosen by the prior, so when fast translations or taps drive
    ``|acc|`` to 0-5 g (10 % of BROAD trial 15's samples have acc pointing *down*), these outliers all
    push the same way: the mean TRIAD error quaternion of that trial is a 39 deg rotation about east,
    and the tuned filter drifted to 40 deg of inclination error (Madgwick's and Mahony's vector
    corrections vanish for a reversed vector instead). ``acc_gate`` skips the TRIAD update when
    ``| |acc| - g | > acc_gate g`` (``g`` from ``rec.units["acc"]``, :func:`gravity_in_units`);
    ``huber_deg`` scales ``R_k`` by ``d / huber`` when the innovation angle
    ``d = 2 acos|z . q^-|`` exceeds it (a Huber M-estimate: the correction stops growing with the
    error, as Madgwick's normalised step). Both default to ``inf`` (off).
  * Robust blocks (:mod:`objectives.attitude.filters.robust`, all off by default = the paper's filter,
    bit for bit): ``acc_lp_tau_s`` feeds the TRIAD an earth-frame low-pass of the accelerometer (fast
    translation: BROAD trial 15 from 53 to < 5 deg), ``mag_rejection`` (with ``mag_norm_th``,
    ``mag_dip_th_deg``, ``mag_max_rejection_s``) leaves the heading to the gyro while the field's norm
    or dip departs from a reference learned when undisturbed, ``rest_bias`` (``rest_bias_var``)
    measures the gyro bias at detected rest. Kernel: :func:`~objectives.attitude.filters.ekf.kernel.ekf_robust_kernel`;
    leave-one-group-out CV on BROAD: ``benchmarks/results/broad_cv.md``.
- The fuzzy sets (Figure 3) and the singletons are not in the text; our defaults are documented at
  :data:`FUZZY_DEFAULTS` and :data:`K_DEFAULTS`, and can be tuned (section 5.3's future work item 3).
"""

from __future__ import annotations

import math
from typing import Any, ClassVar

import numpy as np

from objectives.attitude.cexport.port import ROBUST_MEMBERS, CField, CMember, CPort, RenderContext
from objectives.attitude.data.recording import Recording
from objectives.attitude.filters.base import G_SI, AttitudeFilter, FilterResult, KernelSetup, gravity_in_units
from objectives.attitude.filters.ekf.kernel import C, X, ekf_kernel, ekf_robust_kernel, ekf_steps
from objectives.attitude.filters.ekf.population import EKF_POPULATION
from objectives.attitude.filters.robust import acc_lp_coefficients, mag_dist_coefficients, rest_coefficients
from objectives.attitude.filters.robust_params import robust_decl
from objectives.attitude.filters.stream import StateStream
from objectives.params import POSITIVE, Interval, Param, ParamSet

__all__ = ["EKF", "DECL", "EKF_DECL", "ROBUST_DECL", "GATE_RANGE"]


GATE_RANGE = Interval(0.0, math.inf, low_open=True, allow_inf=True)

#: the EKF's parameters (per sample at the recording's rate, see the module docstring)
EKF_DECL: tuple[Param, ...] = (
    Param("q_q", 1.45e-6, (1e-9, 1e-3), "log", "1 per sample",
          "process noise variance of each quaternion component per sample "
          "(eq. 36 Q_q; paper 1.45e-6 at 1 kHz)",
          "eq. 36 Q_q", POSITIVE),
    Param("q_w", 9.71e-10, (1e-13, 1e-6), "log", "(rad/s)^2 per sample",
          "gyro-bias random-walk variance per sample (eq. 36 Q_omega; paper 9.71e-10 at 1 kHz)",
          "eq. 36 Q_omega", POSITIVE),
    # rho up to 1e3 (was 1e2, where the tuned EKF of the 6-DOF bench sat at the bound): the filter
    # depends on q_q / rho (time constant of the TRIAD correction) and on p0_q / rho (trust in the
    # initial state), so a large rho with the fixed P0 is a legitimate optimum, not a wrong one.
    Param("rho", 3.53, (1e-3, 1e3), "log", "1",
          "variance of each TRIAD quaternion component (eq. 36 R = rho I4; paper 3.53)", "eq. 36 R = rho I4",
          POSITIVE),
    Param("use_mag", True, choices=(True, False), doc="9-D TRIAD with the magnetometer; false: heading from the gyro"),
    Param("integration", "exact", choices=("exact", "euler"),
          doc="quaternion step: 'exact' (q exp(omega Ts/2)) or 'euler' (eq. 16, first order)", eq="eq. 16"),
    Param("p0_q", 1e-2, unit="1", doc="initial variance of each quaternion component (P0, eq. 18)", eq="eq. 18 P0",
          allowed=POSITIVE),
    Param("p0_b", 1e-6, unit="(rad/s)^2", doc="initial variance of each gyro-bias component (P0, eq. 18)",
          eq="eq. 18 P0", allowed=POSITIVE),
    Param("acc_gate", math.inf, unit="1", allowed=GATE_RANGE,
          doc="skip the TRIAD update when | |acc| - g | > acc_gate g (inf: never, as the paper)"),
    Param("huber_deg", math.inf, unit="deg", allowed=GATE_RANGE,
          doc="innovation angle beyond which R grows in proportion to it (inf: never, as the paper)"),
    Param("gyro_sample", "previous", choices=("previous", "current"),
          doc="gyro sample that propagates k-1 -> k: 'previous' (k-1, eq. 16) or 'current' (k, BROAD)"),
)

#: robust blocks (objectives.attitude.filters.robust) in the EKF kernel; all off by default = the paper's EKF
ROBUST_DECL = robust_decl("the TRIAD", "a rejected field leaves the heading to the gyro")
#: the one declaration of the EKF's parameters (defaults, search space, validation, docs, the C port's params)
DECL = ParamSet("ekf", EKF_DECL + ROBUST_DECL)


def _c_fields(v: dict, ctx: RenderContext) -> list[CField]:
    """Gravity in the accelerometer's unit, which the C compares ``|acc|`` with (``acc_gate``, rest detection)."""
    return [CField("real", "g", ctx.g, "gravity in the accelerometer's unit")]


#: the C port (port.c, ported from kernel.py; the robust blocks and sine/cosine of the shared parts)
C_PORT = CPort((__package__, "port.c"), ("robust.c", "trig.c"), (
    CMember("real", "x", (X.LEN,), "state: quaternion (working frame NED) and gyro bias, rad/s (layout X)"),
    CMember("real", "P", (X.LEN, X.LEN), "its covariance"),
    CMember("real", "prev_gyr", (3,), "the previous gyro sample"),
    CMember("real", "mag_gain", (), "the last sample's magnetometer gain (1: used fully)"),
    *ROBUST_MEMBERS), layouts=(X,), fields=_c_fields, gravity=True)


class EKF(AttitudeFilter):
    """Quaternion EKF with TRIAD measurement (FAEKF paper eqs. 16-22, noise of eq. 36).

    Parameters (per-sample definitions of the paper at 1 kHz; see the module docstring)
    ----------
    q_q : float
        Process noise variance of each quaternion component per sample.
    q_w : float
        Gyro-bias random-walk variance per sample, (rad/s)^2.
    rho : float
        Measurement noise variance of each TRIAD quaternion component.
    use_mag : bool
        Fixed option; False runs without magnetometer (tilt from acc, heading from the gyro).
    integration : {"exact", "euler"}
        Fixed option: quaternion step of the time update (see the module docstring).
    p0_q, p0_b : float
        Fixed options: initial covariance ``P0 = diag(p0_q I4, p0_b I3)``; the bias starts at 0.
    acc_gate : float
        Fixed option (inf): skip TRIAD updates when ``| |acc| - g | > acc_gate g``.
    huber_deg : float
        Fixed option (inf), deg: innovation angle beyond which ``R`` grows in proportion to it.
    gyro_sample : {"previous", "current"}
        Fixed option: gyro sample propagating ``k-1 -> k`` (see the module docstring).

    Diagnostics of :meth:`run_detailed`: ``gyr_bias`` (N, 3) rad/s.
    """

    name: ClassVar[str] = "ekf"
    decl: ClassVar[ParamSet] = DECL
    population = EKF_POPULATION
    c_port = C_PORT
    working_frame: ClassVar[str] = "NED"
    needs_mag: ClassVar[bool] = True

    def kernel_setup(self, dt: float, use_mag: bool, q0: np.ndarray, frame: str, g_ref: float = G_SI) -> KernelSetup:
        """The kernel's coefficient array (layout :data:`~objectives.attitude.filters.ekf.kernel.C`; ``g_ref``:
        g in acc units, for ``acc_gate``) and the start state ``x = (q0, 0, 0, 0)`` (layout ``X``; eq. 18: zero
        bias); ``frame`` does not enter (NED)."""
        v = self.values
        coef = C.pack(DT=dt, QQ=v["q_q"], QW=v["q_w"], RHO=v["rho"], P0Q=v["p0_q"], P0B=v["p0_b"],
                      USE_MAG=1.0 if use_mag else 0.0, EXACT=1.0 if v["integration"] == "exact" else 0.0,
                      GATE=v["acc_gate"], G=g_ref, HUBER=math.radians(v["huber_deg"]),
                      CUR=1.0 if v["gyro_sample"] == "current" else 0.0)
        return KernelSetup(coef, X.pack(Q=q0, BIAS=(0.0, 0.0, 0.0)))

    def _inputs(self, rec: Recording) -> tuple[np.ndarray, np.ndarray, np.ndarray, bool]:
        gyr = np.ascontiguousarray(rec.gyr, dtype=np.float64)
        acc = np.ascontiguousarray(rec.acc, dtype=np.float64)
        use_mag = bool(self.values["use_mag"]) and rec.mag is not None
        mag = np.ascontiguousarray(rec.mag, dtype=np.float64) if use_mag else np.zeros((1, 3))
        return gyr, acc, mag, use_mag

    @property
    def robust(self) -> bool:
        """True when any robust block is on (the kernel with the blocks runs; else the paper's)."""
        v = self.values
        return bool(v["mag_rejection"]) or bool(v["rest_bias"]) or float(v["acc_lp_tau_s"]) > 0

    def _kernel(self, rec: Recording, q0: np.ndarray, kscale: np.ndarray) -> tuple[np.ndarray, np.ndarray, dict]:
        """Quaternions (N, 4), gyro bias (N, 3) and the robust blocks' diagnostics (empty when off)."""
        gyr, acc, mag, use_mag = self._inputs(rec)
        n = rec.n
        out_q = np.empty((n, 4))
        out_b = np.empty((n, 3))
        g = gravity_in_units(rec)
        setup = self.kernel_setup(rec.dt, use_mag, q0, rec.frame, g)
        coef, x0 = setup.coef, setup.state
        if not self.robust:
            ekf_kernel(gyr, acc, mag, coef, kscale, x0, out_q, out_b)
            return out_q, out_b, {}
        v = self.values
        tau = float(v["acc_lp_tau_s"])
        flags = np.array([float(bool(v["mag_rejection"])), float(bool(v["rest_bias"])), float(tau > 0),
                          float(v["rest_bias_var"])])
        mcoef = mag_dist_coefficients(rec.dt, norm_th=float(v["mag_norm_th"]), dip_th_deg=float(v["mag_dip_th_deg"]),
                                      max_rejection_s=float(v["mag_max_rejection_s"]))
        rcoef = rest_coefficients(rec.dt, th_acc=0.5 * g / 9.81)
        acoef = acc_lp_coefficients(rec.dt, tau_acc_s=tau, gravity=g)
        out_d = np.empty((n, 2))
        ekf_robust_kernel(gyr, acc, mag, coef, np.ascontiguousarray(kscale, dtype=np.float64), flags, mcoef, rcoef,
                          acoef, x0, out_q, out_b, out_d)
        return out_q, out_b, {"mag_gain": out_d[:, 0], "rest": out_d[:, 1]}

    def _run(self, rec: Recording, q0: np.ndarray) -> FilterResult:
        q, b, extra = self._kernel(rec, q0, np.ones(1))
        return FilterResult(q, self.working_frame, {"gyr_bias": b, **extra})

    def stream(self, rate_hz: float | None = None, dt: float | None = None, q0: Any = None, frame: str = "ENU"):
        """O(1) per-sample EKF (state and covariance carried between :func:`ekf_steps` calls); the
        accelerometer is in m/s^2 as for :meth:`run` on arrays. With a robust block on, the buffered
        fallback of :class:`AttitudeFilter` (equal to :meth:`run`)."""
        if self.robust:
            return AttitudeFilter.stream(self, rate_hz, dt, q0, frame)
        return _EKFStream(self, rate_hz, dt, q0, frame)


class _EKFStream(StateStream):
    """Per-sample EKF: sample 0 is the initial state, every later sample one :func:`ekf_steps` call on
    the (previous, current) pair, which is what the batch kernel does at that sample."""

    def _init_state(self, q0: np.ndarray) -> np.ndarray:
        setup = self.filter.kernel_setup(self.dt, bool(self.use_mag), q0, self.frame)
        self._coef = setup.coef
        self._P = np.zeros((7, 7))
        for i in range(4):
            self._P[i, i] = self._coef[4]
        for i in range(4, 7):
            self._P[i, i] = self._coef[5]
        x = setup.state
        nq = math.sqrt(x[0] * x[0] + x[1] * x[1] + x[2] * x[2] + x[3] * x[3])
        x[:4] = [x[0] / nq, x[1] / nq, x[2] / nq, x[3] / nq]
        self._pair = (np.zeros((2, 3)), np.zeros((2, 3)), np.zeros((2, 3)))
        self._out_q = np.empty((2, 4))
        self._out_b = np.empty((2, 3))
        self._one = np.ones(1)
        return x

    def _step(self, state, gyr, acc, mag):
        g2, a2, m2 = self._pair
        g2[0], a2[0], m2[0] = g2[1], a2[1], m2[1]
        g2[1], a2[1] = gyr[0], acc[0]
        if mag.shape[0]:
            m2[1] = mag[0]
        if self.n == 0:  # sample 0: the initial state, as ekf_kernel writes it
            return state[:4].copy()
        ekf_steps(g2, a2, m2, self._coef, self._one, state, self._P, 1, self._out_q, self._out_b)
        return self._out_q[1].copy()
