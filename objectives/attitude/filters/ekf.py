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
    measures the gyro bias at detected rest. Kernel: :func:`~objectives.attitude.filters._ekf_kernel.ekf_robust_kernel`;
    leave-one-group-out CV on BROAD: ``benchmarks/results/broad_cv.md``.
- The fuzzy sets (Figure 3) and the singletons are not in the text; our defaults are documented at
  :data:`FUZZY_DEFAULTS` and :data:`K_DEFAULTS`, and can be tuned (section 5.3's future work item 3).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np
from numba import njit

from objectives.attitude.data.recording import Recording
from objectives.attitude.filters._ekf_kernel import ekf_kernel, ekf_robust_kernel, ekf_steps
from objectives.attitude.filters.base import G_SI, AttitudeFilter, FilterResult, KernelSetup
from objectives.attitude.filters.robust import acc_lp_coefficients, mag_dist_coefficients, rest_coefficients
from objectives.attitude.filters.robust_params import ROBUST_SWITCHES, robust_decl
from objectives.attitude.filters.stream import StateStream
from objectives.fuzzy import fuzzify, grid_rules, sugeno_mu
from objectives.jit import uncached
from objectives.params import ANY_REAL, POSITIVE, Interval, Param, ParamSet
from tuner.space import Real, Space

__all__ = [
    "EKF", "FAEKF", "FUZZY_DEFAULTS", "K_DEFAULTS", "SEARCHED_K", "FUZZY_INPUTS", "FUZZY_SETS",
    "ekf_kernel", "fuzzy_scale", "gravity_in_units", "rule_consequent_index", "Disturbances", "faekf_rules",
]


# ---------------------------------------------------------------------------------------------
# fuzzy scaling of R (section 4.3, eqs. 28-31, Table 1)
# ---------------------------------------------------------------------------------------------
#: fuzzy inputs in kernel order: vibration frequency (Hz), external acceleration (g), magnetic
#: perturbation (normalised units)
FUZZY_INPUTS = ("vib", "acc", "mag")
FUZZY_UNITS = {"vib": "Hz", "acc": "g", "mag": "nu"}
FUZZY_SETS = ("Z", "S", "B")

#: Default Gaussian sets ``(mean, std)`` per input and set. Figure 3 of the paper (the sets) is not
#: in the text; we cover each input's range with three sets whose neighbours cross at 0.5
#: (``std = spacing / (2 sqrt(2 ln 2))``): ``f`` over 0..10 Hz (``f_thr``, eq. 25), ``a_ext`` over
#: 0..1 g and ``h_ext`` over 0..1 nu (the accumulated measures of eqs. 26-27 average the 0-16 g and
#: 0-5 nu peaks of section 5.3 over L = 400 samples; these ranges cover the bench recordings).
FUZZY_DEFAULTS: dict[str, tuple[float, float]] = {
    "vib_Z": (0.0, 2.1233), "vib_S": (5.0, 2.1233), "vib_B": (10.0, 2.1233),
    "acc_Z": (0.0, 0.21233), "acc_S": (0.5, 0.21233), "acc_B": (1.0, 0.21233),
    "mag_Z": (0.0, 0.21233), "mag_S": (0.5, 0.21233), "mag_B": (1.0, 0.21233),
}
#: Default singletons K1..K7 (not in the text). K1 = 1 keeps R in the undisturbed state, as the
#: paper describes ("in these static cases, the adaptive strategy does not modify the noise
#: variances"); the others grow roughly geometrically up to 100.
K_DEFAULTS = (1.0, 2.0, 5.0, 10.0, 20.0, 50.0, 100.0)
#: search bounds of the set parameters: (mean low, mean high, std low, std high) per input
FUZZY_BOUNDS = {"vib": (0.0, 10.0, 0.1, 10.0), "acc": (0.0, 2.0, 0.01, 2.0), "mag": (0.0, 2.0, 0.01, 2.0)}
#: search bounds of the singletons. The lower bound is 1: Table 1's rules only ever *raise* R with
#: the intensity of the disturbances (section 4.3: "R should be increased according to the intensity
#: of the measures"), and K1 = 1 is the undisturbed state. With K < 1 allowed, PSO on a few short
#: recordings picked K3 ~ 0.3 (the rule of a big magnetic perturbation alone), i.e. trusted the
#: perturbed magnetometer *more*, which fits the training recordings and costs heading on held-out ones.
K_BOUNDS = (1.0, 1000.0)
#: The singletons of the default space: K1 is not searched. R_k = K_k rho (eq. 31) depends on rho and the
#: singletons only through their products, so (c rho, K / c) is the same filter for every c > 0 (tested: bit for
#: bit when c is a power of two): one direction of (rho, K1..K7) changes nothing. Holding K1 at 1, the undisturbed
#: state where "the adaptive strategy does not modify the noise variances", removes it: rho is then the
#: undisturbed R and K2..K7 >= 1 its growth with the disturbance. With K1 searched, the better optimum of the
#: bench6dof problem was a thin ridge along that direction; PSO with the paper's settings (30 x 30) found it
#: in 2 of 10 seeds with K1 searched and in 19 of 30 with K1 = 1, the trust region in 26 of 30
#: (benchmarks/results/auto_rules.md). A ``parameters:`` section that gives K1 bounds searches it.
SEARCHED_K = ("K2", "K3", "K4", "K5", "K6", "K7")


def rule_consequent_index(i_f: int, i_a: int, i_h: int) -> int:
    """Table 1: rule with set indices (0=Z, 1=S, 2=B) of f, a_ext, h_ext -> 0-based index of its K."""
    return i_f + i_a + i_h


def faekf_rules(kappa: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Table 1 as arrays for :mod:`objectives.fuzzy`: (27, 3) antecedents and (27,) consequents."""
    rules = grid_rules([3, 3, 3])
    return rules, np.ascontiguousarray(np.asarray(kappa, dtype=np.float64)[rules.sum(axis=1)])


@njit(cache=True)
def fuzzy_scale(vib, acc, mag, mf_kind, mf_params, rules, consequents, out):
    """Crisp scale ``K_k`` of R for every sample (eqs. 28-31, Table 1), with :mod:`objectives.fuzzy`.

    Parameters
    ----------
    vib, acc, mag : (N,) float64
        Vibration frequency (Hz), external acceleration (g), magnetic perturbation (nu).
    mf_kind, mf_params : (3, 3) int64, (3, 3, 4) float64
        Gaussian sets ``(mean, std)`` of the inputs (vib, acc, mag) x sets (Z, S, B).
    rules, consequents : (27, 3) int64, (27,) float64
        Table 1 (:func:`faekf_rules`).
    out : (N,) float64, out
        ``K = sum_i kappa^i gamma^i / sum_i gamma^i`` with ``gamma^i`` the min of the rule's three
        memberships (zero-order Sugeno, min-AND). If no rule fires (every membership underflows)
        the output is the mean of the singletons (:func:`objectives.fuzzy.sugeno_mu`).
    """
    n = vib.shape[0]
    mu = np.empty(mf_kind.shape)
    xk = np.empty(3)
    for k in range(n):
        xk[0] = vib[k]
        xk[1] = acc[k]
        xk[2] = mag[k]
        fuzzify(xk, mf_kind, mf_params, mu)
        out[k] = sugeno_mu(mu, rules, consequents, 0, np.nan)


#: the uncached twin other kernels call (objectives.jit)
fuzzy_scale_inner = uncached(fuzzy_scale)


# ---------------------------------------------------------------------------------------------
# filter classes
# ---------------------------------------------------------------------------------------------
def _mf_name(inp: str, s: str, what: str) -> str:
    return f"{inp}_{s}_{what}_{FUZZY_UNITS[inp]}"


def _fuzzy_params(tunable: bool) -> tuple[Real, ...]:
    out = []
    for inp in FUZZY_INPUTS:
        lo_m, hi_m, lo_s, hi_s = FUZZY_BOUNDS[inp]
        for s in FUZZY_SETS:
            mean, std = FUZZY_DEFAULTS[f"{inp}_{s}"]
            n_mean, n_std = _mf_name(inp, s, "mean"), _mf_name(inp, s, "std")
            d_mean = f"centre of the Gaussian set {s} of the {inp} input (eq. 28 b_ij)"
            d_std = f"standard deviation of the Gaussian set {s} of the {inp} input (eq. 28 c_ij)"
            if tunable:
                out.append(Real(n_mean, lo_m, hi_m, unit=FUZZY_UNITS[inp], doc=d_mean))
                out.append(Real(n_std, lo_s, hi_s, scale="log", unit=FUZZY_UNITS[inp], doc=d_std))
            else:
                out.append(Real(n_mean, fixed=mean, unit=FUZZY_UNITS[inp], doc=d_mean))
                out.append(Real(n_std, fixed=std, unit=FUZZY_UNITS[inp], doc=d_std))
    return tuple(out)


def _fuzzy_decl() -> tuple[Param, ...]:
    """The 18 set parameters as declarations (fixed by default; bounds in :data:`FUZZY_BOUNDS`)."""
    out = []
    for r in _fuzzy_params(tunable=False):
        std = r.name.split("_")[2] == "std"
        out.append(Param(r.name, r.fixed, unit=r.unit, doc=r.doc, eq="eq. 28", allowed=POSITIVE if std else ANY_REAL))
    return tuple(out)


_GATE_RANGE = Interval(0.0, math.inf, low_open=True, allow_inf=True)

#: the EKF's parameters (per sample at the recording's rate, see the module docstring)
_EKF_DECL: tuple[Param, ...] = (
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
    Param("acc_gate", math.inf, unit="1", allowed=_GATE_RANGE,
          doc="skip the TRIAD update when | |acc| - g | > acc_gate g (inf: never, as the paper)"),
    Param("huber_deg", math.inf, unit="deg", allowed=_GATE_RANGE,
          doc="innovation angle beyond which R grows in proportion to it (inf: never, as the paper)"),
    Param("gyro_sample", "previous", choices=("previous", "current"),
          doc="gyro sample that propagates k-1 -> k: 'previous' (k-1, eq. 16) or 'current' (k, BROAD)"),
)

#: robust blocks (objectives.attitude.filters.robust) in the EKF kernel; all off by default = the paper's EKF
_ROBUST_DECL = robust_decl("the TRIAD", "a rejected field leaves the heading to the gyro")
_ROBUST_NAMES = ROBUST_SWITCHES


def gravity_in_units(rec: Recording) -> float:
    """Standard gravity in the recording's accelerometer unit (``m/s^2`` or ``g``); else the median
    ``|acc|`` of the recording (a recording at rest most of the time reads g)."""
    unit = str(rec.units.get("acc", "")).replace(" ", "").lower()
    if unit in ("m/s^2", "m/s2", "m/s**2", "ms^-2"):
        return 9.80665
    if unit == "g":
        return 1.0
    return float(np.median(np.linalg.norm(rec.acc, axis=1)))


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
    batch_kernel: ClassVar[str | None] = "ekf"
    decl: ClassVar[ParamSet] = ParamSet("ekf", _EKF_DECL + _ROBUST_DECL)
    working_frame: ClassVar[str] = "NED"
    needs_mag: ClassVar[bool] = True

    def kernel_setup(self, dt: float, use_mag: bool, q0: np.ndarray, frame: str, g_ref: float = G_SI) -> KernelSetup:
        """The kernel's (12,) coefficient array (see :func:`ekf_kernel`; ``g_ref``: g in acc units, for
        ``acc_gate``) and the start state ``x = (q0, 0, 0, 0)`` (eq. 18: zero bias); ``frame`` does not enter
        (NED)."""
        v = self.values
        coef = np.array([dt, v["q_q"], v["q_w"], v["rho"], v["p0_q"], v["p0_b"], 1.0 if use_mag else 0.0,
                         1.0 if v["integration"] == "exact" else 0.0, v["acc_gate"], g_ref,
                         math.radians(v["huber_deg"]), 1.0 if v["gyro_sample"] == "current" else 0.0])
        x0 = np.zeros(7)
        x0[:4] = q0
        return KernelSetup(coef, x0)

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


@dataclass(frozen=True)
class Disturbances:
    """The three fuzzy inputs of the FAEKF for every sample (section 4.1-4.2).

    vib_freq_hz : (N,) oscillation frequency estimate ``f`` (eqs. 23-25), Hz.
    ext_acc_g : (N,) accumulated external acceleration ``a_ext`` (eq. 26), g.
    mag_pert_nu : (N,) accumulated magnetic perturbation ``h_ext`` (eq. 27), normalised units.
    """

    vib_freq_hz: np.ndarray
    ext_acc_g: np.ndarray
    mag_pert_nu: np.ndarray


class FAEKF(EKF):
    """Fuzzy-adaptive EKF: the :class:`EKF` with ``R_k = K_k R`` (FAEKF paper section 4, eqs. 23-31).

    Parameters
    ----------
    q_q, q_w, rho, use_mag, p0_q, p0_b
        As :class:`EKF`.
    K1 ... K7 : float
        Singleton consequents of Table 1. K2..K7 are searched in the default space (log scale 1-1000,
        :data:`K_BOUNDS`); K1 stays at 1, the undisturbed state, because only the products
        ``K_j rho`` matter (:data:`SEARCHED_K`).
    {vib,acc,mag}_{Z,S,B}_{mean,std}_{Hz,g,nu} : float
        Centre and standard deviation of each Gaussian set (eq. 28); fixed at :data:`FUZZY_DEFAULTS`
        in the default space, searched by ``FAEKF.space(tune_fuzzy=True)`` within
        :data:`FUZZY_BOUNDS`.
    window : int
        Fixed option: packet / accumulation length L, samples (paper: 400).
    fft_length : int
        Fixed option: L_FFT (paper: 512).
    f_thr : float
        Fixed option: highest expected oscillation frequency, Hz (paper: 10).
    omega_thr : float
        Fixed option: amplitude threshold of the vibration estimate, rad/s (paper: 0.26).
    tune_fuzzy : bool
        Fixed option: whether the default space searches the set parameters.

    Diagnostics of :meth:`run_detailed`: ``gyr_bias`` (N, 3), ``K`` (N,), ``vib_freq_hz``,
    ``ext_acc``, ``mag_pert`` (N,).
    """

    name: ClassVar[str] = "faekf"
    batch_kernel: ClassVar[str | None] = "faekf"
    decl: ClassVar[ParamSet] = ParamSet("faekf", (
        *_EKF_DECL,
        *(Param(f"K{i + 1}", K_DEFAULTS[i], K_BOUNDS if f"K{i + 1}" in SEARCHED_K else None, "log", "1",
                f"singleton K{i + 1} of Table 1 (scale of R)", "eq. 31, Table 1", POSITIVE) for i in range(7)),
        *_fuzzy_decl(),
        Param("window", 400, unit="samples", doc="L: window of eqs. 24, 26, 27", eq="eqs. 24, 26, 27",
              allowed=Interval(2.0), integer=True),
        Param("fft_length", 512, unit="samples", doc="L_FFT of eq. 23", eq="eq. 23", allowed=Interval(2.0),
              integer=True),
        Param("f_thr", 10.0, unit="Hz", doc="highest expected oscillation frequency (eq. 25)", eq="eq. 25",
              allowed=POSITIVE),
        Param("omega_thr", 0.26, unit="rad/s", doc="|Omega|_thr of eq. 25", eq="eq. 25", allowed=POSITIVE),
        Param("tune_fuzzy", False, doc="search the fuzzy sets too (FAEKF.space(tune_fuzzy=True))"),
        *_ROBUST_DECL,
    ))

    @classmethod
    def space(cls, tune_fuzzy: bool | None = None) -> Space:
        """Default search space; with ``tune_fuzzy`` the 18 set parameters are searched too."""
        if not tune_fuzzy:
            return Space(cls.params)
        tunable = {p.name: p for p in _fuzzy_params(tunable=True)}
        params = [tunable.get(p.name, p) for p in cls.params]
        params = [Real("tune_fuzzy", fixed=True, doc=p.doc) if p.name == "tune_fuzzy" else p for p in params]
        return Space(params)

    def _check(self) -> None:
        v = self.values
        if v["fft_length"] < v["window"]:
            raise ValueError(
                f"{self.name}: fft_length ({v['fft_length']}) must be >= window ({v['window']})"
            )

    # --- fuzzy system -----------------------------------------------------------------------
    def membership_table(self) -> np.ndarray:
        """(3, 3, 4) ``(mean, std, 0, 0)`` of the sets, inputs (vib, acc, mag) x sets (Z, S, B)."""
        mf = np.zeros((3, 3, 4))
        for j, inp in enumerate(FUZZY_INPUTS):
            for s, name in enumerate(FUZZY_SETS):
                mf[j, s, 0] = self.values[_mf_name(inp, name, "mean")]
                mf[j, s, 1] = self.values[_mf_name(inp, name, "std")]
        return mf

    def singletons(self) -> np.ndarray:
        """(7,) K1..K7."""
        return np.array([self.values[f"K{i + 1}"] for i in range(7)], dtype=np.float64)

    def scale(self, dist: Disturbances) -> np.ndarray:
        """Fuzzy scale ``K_k`` (N,) of R for precomputed disturbance measures (eqs. 28-31)."""
        out = np.empty(dist.vib_freq_hz.shape[0])
        rules, cons = faekf_rules(self.singletons())
        kind = np.zeros((3, 3), dtype=np.int64)  # objectives.fuzzy.GAUSS
        fuzzy_scale(dist.vib_freq_hz, dist.ext_acc_g, dist.mag_pert_nu, kind, self.membership_table(),
                    rules, cons, out)
        return out

    # --- disturbances -----------------------------------------------------------------------
    def disturbances(self, rec: Recording) -> Disturbances:
        """The fuzzy inputs of ``rec`` (depend only on window, fft_length, f_thr, omega_thr).

        Compute once and pass to :meth:`run_detailed` (``disturbances=``) to skip the FFTs when
        only Q, R or the fuzzy system change.
        """
        from objectives.attitude import disturbance as dis

        v = self.values
        vib = dis.vibration_frequency(rec.gyr, rec.dt, v["window"], v["fft_length"], v["omega_thr"],
                                      f_thr=v["f_thr"])
        ext = dis.external_acceleration(rec.acc, v["window"])
        if rec.mag is not None and bool(v["use_mag"]):
            mp = dis.magnetic_perturbation_measure(rec.mag, v["window"])
        else:
            mp = np.zeros(rec.n)
        return self._as_disturbances(rec, vib, ext, mp)

    @staticmethod
    def _as_disturbances(rec: Recording, vib, ext, mp) -> Disturbances:
        arrs = []
        for key, a in (("vib_freq_hz", vib), ("ext_acc_g", ext), ("mag_pert_nu", mp)):
            a = np.ascontiguousarray(np.asarray(a, dtype=np.float64))
            if a.shape != (rec.n,):
                raise ValueError(f"faekf: disturbance {key!r} must have shape ({rec.n},), got {a.shape}")
            if not np.isfinite(a).all():
                raise ValueError(f"faekf: disturbance {key!r} has non-finite values")
            arrs.append(a)
        return Disturbances(*arrs)

    # --- running ----------------------------------------------------------------------------
    def stream(self, rate_hz: float | None = None, dt: float | None = None, q0: Any = None, frame: str = "ENU"):
        """Per-sample FAEKF through the buffered fallback of :class:`AttitudeFilter` (the fuzzy inputs
        need the packets so far). The batch normalises eq. 27 by the median ``|m|`` of the whole
        recording, the stream by that of the samples so far: with the magnetometer they agree over
        the first packet (``window`` samples) only; without it (``use_mag=False``) at every sample."""
        return AttitudeFilter.stream(self, rate_hz, dt, q0, frame)

    def run_detailed(
        self, rec: Recording, q0: Any = None, disturbances: Disturbances | None = None
    ) -> FilterResult:
        """As :meth:`AttitudeFilter.run_detailed`; ``disturbances`` reuses precomputed fuzzy inputs."""
        if disturbances is not None:
            disturbances = self._as_disturbances(rec, disturbances.vib_freq_hz, disturbances.ext_acc_g,
                                                  disturbances.mag_pert_nu)
        self._given = disturbances
        try:
            return super().run_detailed(rec, q0)
        finally:
            self._given = None

    def _run(self, rec: Recording, q0: np.ndarray, disturbances: Disturbances | None = None) -> FilterResult:
        dist = disturbances if disturbances is not None else getattr(self, "_given", None)
        if dist is None:
            dist = self.disturbances(rec)
        k = self.scale(dist)
        q, b, extra = self._kernel(rec, q0, k)
        return FilterResult(q, self.working_frame, {
            "gyr_bias": b, **extra, "K": k, "vib_freq_hz": dist.vib_freq_hz, "ext_acc": dist.ext_acc_g,
            "mag_pert": dist.mag_pert_nu,
        })
