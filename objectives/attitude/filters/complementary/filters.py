"""Linear, nonlinear (PI) and cascaded complementary filters on Euler angles: LCF, NCF, CCF.

Narkhede, Poddar, Walambe, Ghinea, Kotecha, "Cascaded Complementary Filter Architecture for Sensor
Fusion in Attitude Estimation", Sensors 21, 1937 (2021), equations (1)-(14).

All three work on the ZYX Euler angles ``x = (roll phi, pitch theta, yaw psi)`` of the
sensor-to-earth rotation in the NED earth frame (``working_frame = "NED"``; the class converts the
output quaternion ``q = q_z(psi) q_y(theta) q_x(phi)`` to the recording's frame).

Measurement angles ``x_a`` (the paper's accelerometer/magnetometer estimate):

- roll and pitch from the accelerometer, eqs. (4)-(5), evaluated with ``atan2`` (full range). The
  paper writes them for a sensor that reads gravity (+g along body z when level, z down); our
  accelerometer reads specific force, so the kernel uses ``d = -acc``:
  ``phi_a = atan2(d_y, d_z)``, ``theta_a = atan2(-d_x, d_y sin phi_a + d_z cos phi_a)``;
- yaw from the tilt-compensated magnetometer, eq. (6), with ``atan2`` and ``phi_a``, ``theta_a``
  (the current estimate's roll and pitch when the accelerometer sample is unusable). Yaw is
  relative to magnetic north (declination is not modelled).

Gyroscope path: the Euler-angle rates of eqs. (1)-(3) at the current estimate. The text of the
paper has two typesetting errors there; the kernel uses the standard ZYX kinematics
``phi' = p + (q sin phi + r cos phi) tan theta``, ``theta' = q cos phi - r sin phi``,
``psi' = (q sin phi + r cos phi) / cos theta`` (the paper prints ``- r sin theta`` in (2) and a
leading ``p +`` in (3)). ``|cos theta|`` is clamped to 1e-6 near the gimbal-lock pitch of +-90 deg.

Discrete filters (step ``dt``, previous estimate ``x``, error ``e = wrap(x_a - x)``):

- LCF, eq. (8): ``x+ = pred + (1 - alpha) wrap(x_a - pred)``, ``pred = x + dt x_g'``;
- NCF, eq. (10): ``I += Ki e dt``, ``x+ = x + dt (x_g' + Kp e + I)``;
- CCF, eqs. (12)-(14): the NCF prediction ``pred = x + dt (x_g' + Kp e + I)`` followed by the LCF
  blend of eq. (14). The paper's eq. (13) subtracts ``delta omega`` while eq. (14) adds the PI
  term; the kernel follows eq. (14) (the sign that makes the loop converge), so the gyro bias
  estimate is ``-I``.

``alpha`` is the paper's per-sample weight, so the LCF time constant
``tau = alpha dt / (1 - alpha)`` depends on the sampling rate (keep the seed's definition: an
``alpha`` tuned at one rate must be converted for another). Eq. (9) writes the LCF with a time
constant ``tau``; the paper never states its sampling rate, so its ``alpha = 0.7`` fixes a time
constant only together with the logging rate of its datasets. Option ``alpha_rate_hz`` (default 0:
``alpha`` is per sample at the recording's rate, as before) declares the rate ``f_ref`` at which
``alpha`` is defined: the filter keeps its time constant ``tau = alpha / (f_ref (1 - alpha))`` and
uses ``alpha_eff = tau / (tau + dt)`` at the recording's ``dt`` (equal to ``alpha`` when
``dt = 1 / f_ref``). ``Kp`` (1/s) and ``Ki`` (1/s^2) are
continuous-time gains and rate-independent. The paper's grid (Tables 1-2) is ``Kp`` in
{0.1, 1, 25, 75} and ``Ki`` in {0.01, 0.1, 1}, with ``alpha = 0.7`` for CCF.

alpha_mode (LCF, CCF; option, default ``per_sample``):

- ``per_sample``: the seed's behaviour above, bit for bit: the blend of eq. (8) is fed back into the
  state every sample, so ``alpha`` is a per-sample weight (with ``alpha_rate_hz``, one defined at
  ``f_ref``);
- ``tau``: the same recursive blend parametrised by the time constant ``tau_s`` of eq. (9),
  ``alpha = tau / (tau + dt)`` at the recording's ``dt`` (the backward-Euler form of ``1 / (1 + tau
  s)``), and ``Kp`` applied as ``(1 - exp(-Kp dt)) / dt`` (:func:`tau_gains`). The filter then
  means the same at every rate and stays stable for every ``tau_s > 0``, ``Kp >= 0``: the per-sample
  correction is below the error (``alpha`` in (0, 1), ``Kp`` step below 1), while the plain ``Kp dt``
  of eq. (10) overshoots without bound above ``Kp = 2 / dt``. ``alpha`` is not used;
- ``static``: eq. (14) read as written. ``alpha`` multiplies the integrator's output
  ``x_int = (1/s) [x_g' + (Kp + Ki/s)(x_a - x_hat)]`` and ``(1 - alpha)`` the measurement angles,
  ``x_hat = alpha x_int + (1 - alpha) x_a``, with no feedback of the blend into the integrator other
  than through the PI error ``x_a - x_hat = alpha (x_a - x_int)``. This is what eq. (15) transforms:
  ``s^2 + alpha Kp s + alpha Ki`` in the denominator and a direct feed-through ``(1 - alpha)`` of
  ``x_a``. ``alpha`` is then a dimensionless weight of a continuous-time filter, independent of
  the sampling rate (the paper's own definition; the paper states no rate). The state carries
  ``x_int``; the Euler-rate kinematics are evaluated at ``x_int``; at ``alpha = 1`` it is the NCF.

Angle wrap: every angle error and every estimate is wrapped to (-pi, pi]; a pitch that leaves
[-pi/2, pi/2] after a gyro step is mapped to the equivalent ZYX triple
``(phi + pi, pi - theta, psi + pi)``.

Real recordings (BROAD, 285.7 Hz): option ``acc_gate`` (default inf = the paper) skips every
correction when ``| |acc| - g | > acc_gate g``. On BROAD's fast translations ``|acc|`` spans 0-5 g and
the accelerometer points *down* in 10 % of trial 15's samples; the blend of eq. (14) follows such
samples and the yaw of eq. (6), tilt-compensated with those angles, follows them too (tuned CCF:
75 deg total RMSE on that trial; with the gate, 10 deg). Inherent limits that remain (measured
with the gate, grid-tuned on 5 training trials): fast rotations (trial 07, up to 20 rad/s, pitch to
84 deg) 27-37 deg against Madgwick's 5 deg, because the Euler-rate kinematics ``tan theta``,
``1/cos theta`` and the Euler-rate (not body-rate) PI bias state are attitude-dependent and
amplify errors near pitch +-90 deg; and a disturbed magnetometer acts on yaw directly (trial 28:
15-20 deg). A sound remedy is the same cascade on the rotation group (PI and blend on the body-frame
rotation vector between the estimate and the acc/mag attitude), which is a different filter.

Robust options (CCF; off by default, the output then bit for bit the above): ``acc_lp_tau_s`` (earth-frame
accelerometer low-pass feeding eqs. (4)-(6)) and ``mag_rejection`` (with ``mag_norm_th``, ``mag_dip_th_deg``,
``mag_max_rejection_s``: the yaw correction is suspended while the field's norm or dip departs from a
learned reference), the blocks (c) and (a) of :mod:`objectives.attitude.filters.robust` declared once in
:func:`~objectives.attitude.filters.robust_params.robust_decl`; and ``mag_weight`` (a constant factor < 1
on the yaw correction: the heading corrected more slowly than roll and pitch, as VQF's two time
constants). Kernel in :mod:`objectives.attitude.filters.complementary.kernel`.

Degenerate samples: acc zero or non-finite: no correction of any angle (gyro propagation only, the
integral is not updated); mag zero or non-finite, or ``use_mag: false``: no yaw correction
(yaw from the gyroscope only); gyr non-finite: zero rate for that sample.
"""

from __future__ import annotations

import math

import numpy as np

from objectives.attitude.cexport.port import ROBUST_MEMBERS, CField, CMember, CPort, RenderContext
from objectives.attitude.data.recording import Recording
from objectives.attitude.filters.base import G_SI, AttitudeFilter, FilterResult, KernelSetup, gravity_in_units
from objectives.attitude.filters.complementary.kernel import (
    X,
    cf_kernel,
    cf_robust_kernel,
    coefficients,
    euler_zyx_from_quat,
    quat_from_euler_zyx,
    robust_states,
    run_arrays,
    start_state,
)
from objectives.attitude.filters.robust_params import robust_decl
from objectives.attitude.filters.stream import StateStream
from objectives.params import NONNEG, POSITIVE, UNIT_CLOSED, Interval, Param, ParamSet, check_number, imu_arrays

__all__ = ["LCF", "NCF", "CCF", "ALPHA_MODES", "complementary_batch", "quat_from_euler_zyx", "euler_zyx_from_quat",
           "tau_gains"]


def complementary_batch(gyr, acc, mag, dt: float, euler0, alpha: float = 1.0, kp: float = 0.0,
                        ki: float = 0.0, detailed: bool = False, acc_gate: float = math.inf,
                        g_ref: float = 9.80665, static: bool = False):
    """Run the complementary-filter kernel on raw arrays (NED working frame).

    ``alpha < 1, kp = ki = 0`` is the LCF, ``alpha = 1`` the NCF, both the CCF.

    Parameters
    ----------
    gyr, acc : (N, 3)
        rad/s; specific force, any unit.
    mag : (N, 3) or None
        Any unit; None: yaw from the gyroscope only.
    dt : float
        Sample time, s.
    euler0 : (3,)
        Initial roll, pitch, yaw, rad (ZYX, NED).
    alpha : float in [0, 1]
        Per-sample LCF weight of the gyro path.
    kp, ki : float >= 0
        PI gains, 1/s and 1/s^2.
    detailed : bool
        Also return the (N, 3) Euler estimate and the (N, 3) Euler-rate bias estimate.
    acc_gate : float > 0
        Skip every correction (as for an unusable sample) when ``| |acc| - g_ref | > acc_gate g_ref``;
        inf (default): never, as the paper.
    g_ref : float > 0
        Gravity in the accelerometer's unit.
    static : bool
        False (default): the blend is fed back each sample (``alpha`` per sample); True: eq. (14) as
        written, ``x_hat = alpha x_int + (1 - alpha) x_a`` with the PI driven by ``x_a - x_hat``.

    Returns
    -------
    quat : (N, 4) sensor-to-earth NED, or (quat, euler, bias) when ``detailed``.
    """
    own = "complementary"
    gyr, acc, mag = imu_arrays(own, gyr, acc, mag)
    dt = check_number(own, "dt", dt, POSITIVE, "s")
    alpha = check_number(own, "alpha", alpha, ALPHA_RANGE)
    kp = check_number(own, "Kp", kp, NONNEG, "1/s")
    ki = check_number(own, "Ki", ki, NONNEG, "1/s^2")
    acc_gate = check_number(own, "acc_gate", acc_gate, GATE_RANGE)
    g_ref = check_number(own, "g_ref", g_ref, POSITIVE)
    x0 = np.asarray(euler0, dtype=np.float64).reshape(-1)
    if x0.shape != (3,) or not np.all(np.isfinite(x0)):
        raise ValueError(f"{own}: euler0 must be a finite (3,) array of radians, got {euler0!r}")
    return run_arrays(gyr, acc, mag, coefficients(dt, alpha, kp, ki, mag.shape[0] > 0, acc_gate, g_ref, bool(static)),
                       start_state(x0), detailed)


ALPHA_RANGE = UNIT_CLOSED
GATE_RANGE = Interval(0.0, math.inf, low_open=True, allow_inf=True)
_ALPHA = dict(unit="1", doc="gyro weight per sample, eq. (8)", eq="eq. (8)", allowed=ALPHA_RANGE)
_KP = dict(bounds=(0.01, 100.0), scale="log", unit="1/s", doc="proportional gain of eq. (10)", eq="eq. (10)",
           allowed=NONNEG)
_KI = dict(bounds=(1e-3, 10.0), scale="log", unit="1/s^2", doc="integral gain of eq. (10)", eq="eq. (10)",
           allowed=NONNEG)
_ALPHA_RATE = Param("alpha_rate_hz", 0.0, unit="Hz", allowed=NONNEG,
                    doc="rate at which alpha is a per-sample weight (0: the recording's rate)")
#: how ``alpha`` enters: see the module docstring, section "alpha_mode"
ALPHA_MODES = ("per_sample", "tau", "static")
_ALPHA_MODE = Param("alpha_mode", "per_sample", choices=ALPHA_MODES,
                    doc="per_sample: alpha weights each sample (seed); tau: time constant tau_s; static: eq. (14)-(15)")
_TAU = Param("tau_s", 0.1, unit="s", allowed=POSITIVE, eq="eq. (9)",
             doc="time constant of the blend, eq. (9) (alpha_mode tau): alpha = tau / (tau + dt) per sample")


def alpha_at_rate(alpha: float, alpha_rate_hz: float, dt: float) -> float:
    """Per-sample weight at step ``dt`` (s) with the LCF time constant ``alpha`` has at ``alpha_rate_hz``.

    ``tau = alpha / (f_ref (1 - alpha))`` (eqs. (8)-(9) discretised at ``1 / f_ref``),
    ``alpha_eff = tau / (tau + dt)``; ``alpha_rate_hz = 0`` or ``alpha`` in {0, 1} returns ``alpha``.
    """
    if alpha_rate_hz == 0.0 or alpha <= 0.0 or alpha >= 1.0:
        return alpha
    tau_s = alpha / (alpha_rate_hz * (1.0 - alpha))
    return tau_s / (tau_s + dt)


def tau_gains(tau_s: float, kp: float, dt: float) -> tuple[float, float]:
    """Per-sample blend weight and proportional gain of ``alpha_mode: tau`` at step ``dt`` (s).

    ``alpha = tau / (tau + dt)``: the recursive LCF of eq. (8) is then the backward-Euler discretisation of
    eq. (9)'s ``1 / (1 + tau s)`` at every rate, ``0 < alpha < 1`` for every ``tau > 0``. ``Kp`` (1/s) is
    applied as ``(1 - exp(-Kp dt)) / dt``, the exact per-sample decay of ``x' = -Kp x``: the per-sample
    correction stays below the whole error at any rate (the plain ``Kp dt`` exceeds 2, and the loop
    oscillates without bound, above ``Kp = 2 / dt``: 100 1/s at 50 Hz).
    """
    return tau_s / (tau_s + dt), -math.expm1(-kp * dt) / dt


_USE_MAG = Param("use_mag", True, doc="yaw from the magnetometer (true) or gyro only (false)")
_GATE = Param("acc_gate", math.inf, unit="1", allowed=GATE_RANGE,
              doc="no correction when | |acc| - g | > acc_gate g (inf: never, as the paper)")


class _ComplementaryBase(AttitudeFilter):
    """Shared run logic; output sensor-to-earth in the recording's frame (kernel: NED, ZYX Euler).

    ``run_detailed`` adds diagnostics ``euler`` (N, 3) roll/pitch/yaw in NED, rad, and
    ``gyr_bias`` (N, 3), the Euler-rate bias estimate ``-I``, rad/s (zero for the LCF).
    """

    working_frame = "NED"
    needs_mag = True

    def _gains(self) -> tuple[float, float, float]:  # pragma: no cover - abstract
        raise NotImplementedError

    def kernel_setup(self, dt: float, use_mag: bool, q0: np.ndarray, frame: str, g_ref: float = G_SI) -> KernelSetup:
        """The kernel's coefficient array (``kernel.coefficients``: the gains at ``dt`` per ``alpha_mode``,
        ``g_ref`` for ``acc_gate``) and the start state: the ZYX Euler angles of ``q0`` (NED), zero integrals;
        ``frame`` does not enter. ValueError for ``alpha_rate_hz`` with an ``alpha_mode`` other than per_sample."""
        alpha, kp, ki = self._gains()
        mode = self.values.get("alpha_mode", "per_sample")
        rate_hz = float(self.values.get("alpha_rate_hz", 0.0))
        if mode != "per_sample" and rate_hz != 0.0:
            raise ValueError(f"{self.name}: alpha_rate_hz={rate_hz} applies to alpha_mode per_sample only, "
                             f"got alpha_mode {mode!r} (set alpha_rate_hz: 0)")
        if mode == "tau":
            alpha, kp = tau_gains(float(self.values["tau_s"]), kp, dt)
        else:
            alpha = alpha_at_rate(alpha, rate_hz, dt)
        coef = coefficients(dt, alpha, kp, ki, use_mag, float(self.values.get("acc_gate", math.inf)), g_ref,
                     static=mode == "static")
        return KernelSetup(coef, start_state(euler_zyx_from_quat(q0)))

    @property
    def robust(self) -> bool:
        """True when a robust option is on (``acc_lp_tau_s > 0``, ``mag_rejection``, ``mag_weight < 1``; CCF)."""
        v = self.values
        return bool(v.get("mag_rejection", False)) or float(v.get("acc_lp_tau_s", 0.0)) > 0.0 \
            or float(v.get("mag_weight", 1.0)) != 1.0

    def _blocks(self, g_ref: float, dt: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """``(flags, mcoef, rcoef, acoef)`` of ``kernel.cf_robust_kernel``."""
        from objectives.attitude.filters.robust import acc_lp_coefficients, mag_dist_coefficients, rest_coefficients

        v = self.values
        tau = float(v["acc_lp_tau_s"])
        flags = np.array([1.0 if v["mag_rejection"] else 0.0, 1.0 if tau > 0 else 0.0, float(v["mag_weight"])])
        mcoef = mag_dist_coefficients(dt, norm_th=float(v["mag_norm_th"]), dip_th_deg=float(v["mag_dip_th_deg"]),
                                      max_rejection_s=float(v["mag_max_rejection_s"]))
        return flags, mcoef, rest_coefficients(dt, th_acc=0.5 * g_ref / 9.81), \
            acc_lp_coefficients(dt, tau_acc_s=tau, gravity=g_ref)

    def _run(self, rec: Recording, q0: np.ndarray) -> FilterResult:
        gyr, acc, mag = imu_arrays(self.name, rec.gyr, rec.acc, rec.mag if self.values["use_mag"] else None)
        g = gravity_in_units(rec)
        setup = self.kernel_setup(rec.dt, mag.shape[0] > 0, q0, rec.frame, g)
        coef, state = setup.coef, setup.state
        if not self.robust:
            q, euler, bias = run_arrays(gyr, acc, mag, coef, state, detailed=True)
            return FilterResult(q, self.working_frame, {"euler": euler, "gyr_bias": bias})

        n = gyr.shape[0]
        q, euler, bias, gain = np.empty((n, 4)), np.empty((n, 3)), np.empty((n, 3)), np.empty(n)
        cf_robust_kernel(gyr, acc, mag, coef, *self._blocks(g, rec.dt), state, *robust_states(), q, euler, bias,
                         gain)
        return FilterResult(q, self.working_frame, {"euler": euler, "gyr_bias": bias, "mag_gain": gain})

    def stream(self, rate_hz: float | None = None, dt: float | None = None, q0=None, frame: str = "ENU"):
        """O(1) per-sample filter (the kernel carries the Euler angles and integrals in ``state``);
        the accelerometer is in m/s^2 (``g_ref`` = 9.80665) as for :meth:`run` on arrays."""
        return _CFStream(self, rate_hz, dt, q0, frame)


class _CFStream(StateStream):
    def _buffers(self) -> None:
        self._none = np.empty((0, 3))
        self._none1 = np.empty(0)
        self._robust = None
        if self.filter.robust:  # the blocks' coefficients and states, carried between samples
            self._robust = (*self.filter._blocks(G_SI, self.dt), *robust_states())

    def _step(self, state, gyr, acc, mag):
        coef = self._coef
        if self._robust is None:
            cf_kernel(gyr, acc, mag, coef, state, self._out, self._none, self._none)
        else:
            flags, mcoef, rcoef, acoef, ms, rs, ast = self._robust
            cf_robust_kernel(gyr, acc, mag, coef, flags, mcoef, rcoef, acoef, state, ms, rs, ast, self._out,
                             self._none, self._none, self._none1)
        return self._out[0]


#: the robust blocks the CCF offers (robust_params.robust_decl: block (c) and block (a), no rest bias)
_CCF_ROBUST = tuple(p for p in robust_decl("the roll/pitch angles of eqs. (4)-(6)",
                                           "a rejected field leaves the yaw to the gyroscope")
                    if p.name in ("acc_lp_tau_s", "mag_rejection", "mag_max_rejection_s", "mag_norm_th",
                                  "mag_dip_th_deg"))
_MAG_WEIGHT = Param("mag_weight", 1.0, unit="1", allowed=UNIT_CLOSED,
                    doc="factor on the magnetometer's yaw correction (PI and blend; 1: as roll and pitch, the paper): "
                        "< 1 corrects the heading more slowly than the inclination (VQF's tauMag > tauAcc)")


#: the CCF's declaration, the family's complete one: the C port's params are made of it for all three filters
CCF_DECL = ParamSet("ccf", (Param("alpha", 0.7, (0.5, 0.9999), **_ALPHA), Param("Kp", 25.0, **_KP),
                            Param("Ki", 0.1, **_KI), _USE_MAG, _GATE, _ALPHA_RATE, _ALPHA_MODE, _TAU,
                            *_CCF_ROBUST, _MAG_WEIGHT))


def _c_values(flt: _ComplementaryBase) -> dict:
    """The one port's values for any of the three: the filter's own, the gains it runs with (the LCF has no PI
    gains, the NCF no blend: ``_gains``), and the CCF's defaults for the options the filter does not have."""
    v = {**CCF_DECL.defaults(), **flt.values}
    v["alpha"], v["Kp"], v["Ki"] = flt._gains()
    if v["alpha_mode"] != "per_sample" and float(v["alpha_rate_hz"]) != 0.0:
        raise ValueError(f"c-filter: {flt.name}: alpha_rate_hz={v['alpha_rate_hz']} applies to alpha_mode "
                         "per_sample only")
    return v


def _c_fields(v: dict, ctx: RenderContext) -> list[CField]:
    """Gravity in the accelerometer's unit, which the C compares ``|acc|`` with (``acc_gate``)."""
    return [CField("real", "g", ctx.g, "gravity in the accelerometer's unit")]


#: the C port of all three (port.c, ported from kernel.py; the robust blocks, sine/cosine and angle wrapping of
#: the shared parts)
C_PORT = CPort((__package__, "port.c"), ("robust.c", "trig.c", "angle.c"), (
    CMember("real", "x", (X.field("EULER").size,), "roll, pitch, yaw (ZYX, NED), rad: the state"),
    CMember("real", "integ", (X.field("INTEG").size,), "the PI integrals, rad/s"),
    CMember("real", "out", (3,), "the last output angles, rad"),
    CMember("real", "alpha", (), "per-sample gains at dt_s"),
    CMember("real", "kp"),
    CMember("real", "mag_gain", (), "the last factor on the yaw correction"),
    *ROBUST_MEMBERS), decl=CCF_DECL, values=_c_values, fields=_c_fields, gravity=True)


class LCF(_ComplementaryBase):
    """Linear complementary filter, eq. (8). Parameter ``alpha`` (default 0.98), ``use_mag``."""

    name = "lcf"
    decl = ParamSet("lcf", (Param("alpha", 0.98, (0.5, 0.9999), **_ALPHA), _USE_MAG, _ALPHA_RATE, _ALPHA_MODE, _TAU))
    c_port = C_PORT

    def _gains(self):
        return float(self.values["alpha"]), 0.0, 0.0


class NCF(_ComplementaryBase):
    """Nonlinear (PI) complementary filter, eq. (10). ``Kp`` (default 25), ``Ki`` (0.1; Table 4)."""

    name = "ncf"
    decl = ParamSet("ncf", (Param("Kp", 25.0, **_KP), Param("Ki", 0.1, **_KI), _USE_MAG))
    c_port = C_PORT

    def _gains(self):
        return 1.0, float(self.values["Kp"]), float(self.values["Ki"])


class CCF(_ComplementaryBase):
    """Cascaded complementary filter, eq. (14). ``alpha`` (default 0.7, section 4), ``Kp`` 25, ``Ki`` 0.1;
    robust options ``acc_lp_tau_s``, ``mag_rejection``, ``mag_weight`` (off by default: the paper's filter)."""

    name = "ccf"
    decl = CCF_DECL
    c_port = C_PORT

    def _gains(self):
        v = self.values
        return float(v["alpha"]), float(v["Kp"]), float(v["Ki"])
