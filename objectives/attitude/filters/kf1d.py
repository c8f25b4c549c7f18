"""1-D tilt filters of the thesis (Odry 2020, section 3.1): KF, fuzzy-adaptive KF, Mahony and Madgwick.

All four estimate the tilt angle ``theta`` about the sensor **y** axis from the rate ``gyr[:, 1]`` and
the accelerometer's x and z components (the tilt bench of thesis 3.1.2, :func:`tilt1d` of
``objectives.attitude.data.synthetic``). The output quaternion is the rotation about y by the
estimate, ``(cos(theta/2), 0, sin(theta/2), 0)`` in the recording's frame; ``diagnostics["angle"]``
holds ``theta`` (N,) rad.

Angle convention
----------------
``theta`` is the rotation about the sensor y axis that takes the sensor frame to the recording's
earth frame (the truth ``rec.extra["angle"]`` of the tilt bench). The accelerometer realisation of
eq. 3.6 in our axes is ``theta_A = atan2(-s ax, s az)`` with ``s = +1`` in z-up frames (ENU) and
``s = -1`` in NED (the specific force points up). The initial angle comes from the common initial
quaternion (``q0``: first accelerometer sample by default, ``"truth"``, or explicit) through the
sensor's up vector, so it does not depend on heading.

KF1D (thesis eqs. 3.9-3.13, 3.17)
---------------------------------
State ``x = (theta, omega_0)`` (angle, gyro bias), input ``u = Omega = gyr[:, 1]``::

    x_k^- = Phi x_{k-1} + Gamma u_{k-1},  Phi = [[1, -Ts], [0, 1]],  Gamma = [Ts, 0]^T      (3.9, 3.11)
    P_k^- = Phi P_{k-1} Phi^T + Q,  Q = diag(q00, q11)                                        (3.11, 3.17)
    G_k = P_k^- H^T (H P_k^- H^T + R)^-1,  H = [1, 0],  R = rho                               (3.12, 3.17)
    x_k = x_k^- + G_k (theta_A,k - H x_k^-),  P_k = (I - G_k H) P_k^-                          (3.13)

Sample ``k`` is propagated with gyro sample ``k - 1`` (the rate held over ``[t_{k-1}, t_k]``) and
corrected with accelerometer sample ``k``; sample 0 is the initial state ``(theta_0, 0)``, ``P_0``
(thesis: ``0_2x2``). The residual is wrapped to ``(-pi, pi]``.

Units and rate: ``q00``, ``q11``, ``rho`` are per-sample variances as in the thesis (800 Hz; the
thesis states them in degree units). With ``P_0 = 0`` the gain depends only on the ratios of Q and R,
so the same numbers give the same estimate whether angles are in degrees or radians; with a nonzero
``P_0`` (options ``p0_theta``, ``p0_bias``), all five are in rad^2 (and (rad/s)^2) units.

AKF1D (thesis 3.1.4, eqs. 3.19-3.24, Table 3.2)
-----------------------------------------------
``R_k = K_k rho`` where ``K_k`` is a zero-order Sugeno system (min-AND, weighted average, eq. 3.24)
of the vibration frequency ``f_hat`` (Hz, eqs. 3.19-3.21 on ``gyr[:, 1]``) and the average external
acceleration ``alpha_hat`` (g, eq. 3.22), each covered by Z, S, B sets, with the 9 rules of Table 3.2
(``K_{1 + i_f + i_a}``). Both measures come from :mod:`objectives.attitude.disturbance` (packets of
``window`` samples, causal hold). Deviations / documented choices (Fig. 3.9 is missing from the text):

- the sets: "one triangular and two trapezoidal" per input over the ranges the thesis gives (f up to
  6.5 Hz, alpha up to 0.35 g): ``Z = trap(-inf, -inf, 0, r/2)``, ``S = tri(0, r/2, r)``,
  ``B = trap(r/2, r, inf, inf)`` with ``r = f_range_hz`` or ``acc_range_g`` (a uniform partition);
- the singletons ``K1..K5`` (not in the text, "chosen intuitively via iterative tuning"): default
  ``(1, 3, 10, 30, 100)``, half-decade steps so that the biggest disturbance makes the accelerometer
  100 times less trusted; all are options that can be searched;
- ``omega_thr`` default 10 deg/s = 0.1745 rad/s and ``f_thr`` 8 Hz (thesis values; the FAEKF paper
  uses 0.26 rad/s and the FAEKF config 10 Hz).

Mahony1D and Madgwick1D (thesis 3.1.5, Tables 3.4-3.5)
-------------------------------------------------------
The thesis runs Madgwick's sample code (MahonyAHRSupdateIMU, MadgwickAHRSupdateIMU) on the bench
data. On the tilt bench the attitude is a rotation about y only, so the quaternion stays
``(q0, 0, q2, 0)``; these classes run exactly that code restricted to ``(q0, q2)``, with ``ay`` and the
x/z rates dropped (they carry only noise on the bench) and the accelerometer normalised over
``(ax, az)``. Mahony: ``e = a x v`` (= ``sin(theta_A - theta)``), ``I += Ki e Ts`` (only when
``Ki > 0``, else ``I = 0``), ``omega = Omega + Kp e + I``. Madgwick: the normalised gradient step
``s = J^T f / |J^T f|``, ``q_dot = q (x) omega / 2 - beta s``. As in the sample code, call ``k`` uses
gyro and accelerometer sample ``k`` to go from ``t_k`` to ``t_{k+1}``; the output at sample ``k`` is the
state after call ``k - 1`` (sample 0 is the initial state).

Integration (option ``exact_step``): ``True`` (default) rotates ``(q0, q2)`` by the exact angle
``omega Ts`` (the rate is held constant over the sample, as the synthetic benches define it);
``False`` is the sample code's first-order step ``q += q_dot Ts`` then normalisation. They differ by
``(omega Ts)^3 / 12`` rad per sample (4e-7 rad at 800 deg/s and 800 Hz). Madgwick's normalised step
has magnitude ``beta`` whenever the gradient is not exactly zero, so even on perfect data its error
chatters at the level ``beta Ts``.
"""

from __future__ import annotations

import math
from typing import Any, ClassVar

import numpy as np
from numba import njit

from objectives.attitude.data.recording import Recording
from objectives.attitude.filters._kf1d_kernels import kf1d_kernel, madgwick1d_kernel, mahony1d_kernel, tilt_state
from objectives.attitude.filters.base import G_SI, AttitudeFilter, FilterResult, KernelSetup
from objectives.attitude.filters.stream import StateStream
from objectives.fuzzy import TRAP, TRI, SugenoFIS, grid_rules
from objectives.jit import uncached
from objectives.params import NONNEG, POSITIVE, Interval, Param, ParamSet

__all__ = ["KF1D", "AKF1D", "Mahony1D", "Madgwick1D", "kf1d_kernel", "mahony1d_kernel",
           "madgwick1d_kernel", "tilt_from_quat", "quat_from_tilt", "akf1d_fis"]

# --- helpers ------------------------------------------------------------------------------------
def _up_sign(frame: str) -> float:
    return -1.0 if frame.upper() == "NED" else 1.0


def tilt_from_quat(q: np.ndarray, frame: str, q_frame: str = "ENU") -> float:
    """Tilt angle about the sensor y axis (in ``frame``'s convention) of a quaternion in ``q_frame``.

    Uses only the sensor's up vector, so the heading of ``q`` does not matter.
    """
    from objectives.attitude.quaternion import to_frame

    w, x, y, z = to_frame(np.asarray(q, float), q_frame, "ENU")
    ux = 2.0 * (x * z - w * y)       # third row of R(q): earth up in the sensor frame
    uz = w * w - x * x - y * y + z * z
    s = _up_sign(frame)
    return math.atan2(-s * ux, s * uz)


@njit(cache=True)
def _quat_from_tilt(theta, out):
    for k in range(theta.shape[0]):
        h = 0.5 * theta[k]
        out[k, 0] = math.cos(h)
        out[k, 1] = 0.0
        out[k, 2] = math.sin(h)
        out[k, 3] = 0.0


#: the uncached twin other kernels call (objectives.jit)
_quat_from_tilt_inner = uncached(_quat_from_tilt)


def quat_from_tilt(theta: np.ndarray) -> np.ndarray:
    """(N, 4) rotations about y by ``theta`` (N,) rad: ``(cos(theta/2), 0, sin(theta/2), 0)``."""
    theta = np.ascontiguousarray(np.asarray(theta, dtype=float).reshape(-1))
    q = np.empty((theta.shape[0], 4))
    _quat_from_tilt(theta, q)
    return q


def _inputs(rec: Recording) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    gy = np.ascontiguousarray(rec.gyr[:, 1], dtype=np.float64)
    ax = np.ascontiguousarray(rec.acc[:, 0], dtype=np.float64)
    az = np.ascontiguousarray(rec.acc[:, 2], dtype=np.float64)
    return gy, ax, az


# --- KF1D ----------------------------------------------------------------------------------------
_P0_OPTIONS = (
    Param("p0_theta", 0.0, unit="rad^2", doc="initial angle variance (thesis 3.1.3.1: P0 = 0)", eq="eq. 3.13",
          allowed=NONNEG),
    Param("p0_bias", 0.0, unit="(rad/s)^2", doc="initial bias variance (thesis 3.1.3.1: P0 = 0)", eq="eq. 3.13",
          allowed=NONNEG),
)


def _kf_noise(rho, q00, q11, defaults, rho_doc) -> tuple[Param, ...]:
    """rho, q00, q11 with search bounds ``(rho, q00, q11)`` and defaults ``defaults``."""
    return (
        Param("rho", defaults[0], rho, "log", "angle^2 per sample", rho_doc, "eq. 3.17", POSITIVE),
        Param("q00", defaults[1], q00, "log", "angle^2 per sample", "angle process noise (eq. 3.17)", "eq. 3.17",
              POSITIVE),
        Param("q11", defaults[2], q11, "log", "(angle/s)^2 per sample", "gyro-bias random-walk variance (eq. 3.17)",
              "eq. 3.17", POSITIVE),
    )


class KF1D(AttitudeFilter):
    """2-state tilt Kalman filter of thesis eqs. 3.9-3.13 (see the module docstring).

    Parameters
    ----------
    rho : float
        Measurement noise variance of the accelerometer angle (eq. 3.17 ``R = rho``), per sample.
    q00, q11 : float
        Process noise variances of the angle and of the bias random walk (eq. 3.17), per sample.
    p0_theta, p0_bias : float
        Fixed options: ``P0 = diag(p0_theta, p0_bias)`` (thesis: 0).

    Defaults are the thesis's initial values (3.1.3.1): ``q00 = 5e-7``, ``q11 = 5e-9``,
    ``rho = 1e5 q00 = 0.05``. The default search space spans both runs of Table 3.1: rho in
    [0.008, 0.45], q00 in [7e-9, 2e-6]; q11 in [1e-13, 2e-8] (the second run's q11 bounds are
    unreadable in the text; its optimum 3.08e-12 lies below the first run's 1e-10, so the lower bound
    is a documented choice). Thesis optimum (second run, Table 3.1): rho 0.35459, q00 6.38e-8,
    q11 3.08e-12, F = 1.9077 deg^2.

    Diagnostics: ``angle`` (N,) rad, ``gyr_bias`` (N,) rad/s.
    """

    name: ClassVar[str] = "kf1d"
    batch_kernel: ClassVar[str | None] = "kf1d"
    decl: ClassVar[ParamSet] = ParamSet("kf1d", _kf_noise(
        (0.008, 0.45), (7e-9, 2e-6), (1e-13, 2e-8), (0.05, 5e-7, 5e-9),
        "accelerometer-angle noise variance R (eq. 3.17)") + _P0_OPTIONS)

    def kernel_setup(self, dt: float, use_mag: bool, q0: np.ndarray, frame: str, g_ref: float = G_SI) -> KernelSetup:
        """The kernel's ``(Ts, q00, q11, rho)`` (eqs. 3.11, 3.17) and start state ``(theta_0, 0, P_0)``
        (:func:`~objectives.attitude.filters._kf1d_kernels.kf1d_kernel`'s layout), ``theta_0`` the tilt of
        ``q0`` in ``frame``'s convention (:func:`tilt_from_quat`); ``use_mag`` and ``g_ref`` do not enter."""
        v = self.values
        theta0 = tilt_from_quat(q0, frame, self.working_frame)
        return KernelSetup(np.array([dt, v["q00"], v["q11"], v["rho"]]),
                           np.array([theta0, 0.0, v["p0_theta"], 0.0, v["p0_bias"]]))

    def _kf(self, rec: Recording, q0: np.ndarray, kscale: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        gy, ax, az = _inputs(rec)
        th = np.empty(rec.n)
        b = np.empty(rec.n)
        setup = self.kernel_setup(rec.dt, False, q0, rec.frame)
        kf1d_kernel(gy, ax, az, _up_sign(rec.frame), setup.coef, kscale, setup.state, 1, th, b)
        return th, b

    def _run(self, rec: Recording, q0: np.ndarray) -> FilterResult:
        th, b = self._kf(rec, q0, np.ones(1))
        return FilterResult(quat_from_tilt(th), rec.frame, {"angle": th, "gyr_bias": b})

    def stream(self, rate_hz: float | None = None, dt: float | None = None, q0: Any = None, frame: str = "ENU"):
        """O(1) per-sample tilt KF (the kernel carries angle, bias and covariance in ``state``)."""
        return _TiltStream(self, rate_hz, dt, q0, frame)


# --- AKF1D ---------------------------------------------------------------------------------------
#: K1..K5 defaults (not in the text; see the module docstring)
AKF1D_K_DEFAULTS = (1.0, 3.0, 10.0, 30.0, 100.0)


def akf1d_fis(f_range_hz: float, acc_range_g: float, kappa: Any) -> SugenoFIS:
    """The 9-rule Sugeno system of thesis Table 3.2 / eq. 3.24 with the sets of the module docstring.

    Inputs ``(f_hat Hz, alpha_hat g)``; rule ``(i_f, i_a)`` -> ``K_{1 + i_f + i_a}``.
    """
    params = np.zeros((2, 3, 4))
    kinds = np.array([[TRAP, TRI, TRAP], [TRAP, TRI, TRAP]])
    for j, r in enumerate((float(f_range_hz), float(acc_range_g))):
        h = 0.5 * r
        params[j, 0] = (-np.inf, -np.inf, 0.0, h)
        params[j, 1] = (0.0, h, r, 0.0)
        params[j, 2] = (h, r, np.inf, np.inf)
    rules = grid_rules([3, 3])
    kappa = np.asarray(kappa, dtype=float).reshape(-1)
    if kappa.shape != (5,):
        raise ValueError(f"akf1d: need the 5 singletons K1..K5, got {kappa.size}")
    return SugenoFIS(kinds, params, rules, kappa[rules.sum(axis=1)], and_op="min")


class AKF1D(KF1D):
    """Fuzzy-adaptive tilt KF of thesis 3.1.4: ``R_k = K_k rho`` (eq. 3.24); see the module docstring.

    Parameters
    ----------
    rho, q00, q11, p0_theta, p0_bias : as :class:`KF1D`.
        Defaults: the initial values of Table 3.3 (rho 0.05, q00 7e-8, q11 5e-12); search space: both
        runs of Table 3.3 (rho [0.005, 0.43], q00 [1e-8, 8e-7], q11 [1e-12, 5e-11]). Thesis optimum
        (second run): rho 0.31969, q00 5.86e-7, q11 6.43e-12, F = 1.6990 deg^2.
    window, fft_length : int, fixed
        Packet length L = 400 and FFT length 512 (eqs. 3.19-3.22).
    f_thr : float, fixed
        Highest vibration frequency considered, Hz (thesis: 8).
    omega_thr : float, fixed
        Amplitude threshold, rad/s (thesis: 10 deg/s).
    f_range_hz, acc_range_g : float, fixed
        Ranges of the fuzzy inputs (thesis: 6.5 Hz and 0.35 g).
    K1..K5 : float, fixed
        Singleton consequents of Table 3.2.

    Diagnostics: ``angle``, ``gyr_bias``, ``K`` (N,), ``vib_freq_hz`` (N,), ``ext_acc`` (N,) g.
    """

    name: ClassVar[str] = "akf1d"
    batch_kernel: ClassVar[str | None] = None  # the fuzzy scale of R: serial only
    decl: ClassVar[ParamSet] = ParamSet("akf1d", _kf_noise(
        (0.005, 0.43), (1e-8, 8e-7), (1e-12, 5e-11), (0.05, 7e-8, 5e-12),
        "accelerometer-angle noise variance before fuzzy scaling (eq. 3.24)") + _P0_OPTIONS + (
        Param("window", 400, unit="samples", doc="packet length L (eqs. 3.19-3.22)", eq="eqs. 3.19-3.22",
              allowed=Interval(2.0), integer=True),
        Param("fft_length", 512, unit="samples", doc="FFT length L_FFT (eq. 3.19)", eq="eq. 3.19",
              allowed=Interval(2.0), integer=True),
        Param("f_thr", 8.0, unit="Hz", doc="highest vibration frequency considered (eq. 3.21)", eq="eq. 3.21",
              allowed=POSITIVE),
        Param("omega_thr", math.radians(10.0), unit="rad/s", doc="amplitude threshold (eq. 3.21)", eq="eq. 3.21",
              allowed=NONNEG),
        Param("f_range_hz", 6.5, unit="Hz", doc="range of the vibration input (sets Z, S, B)", eq="Table 3.2",
              allowed=POSITIVE),
        Param("acc_range_g", 0.35, unit="g", doc="range of the external-acceleration input", eq="Table 3.2",
              allowed=POSITIVE),
    ) + tuple(Param(f"K{i + 1}", k, unit="1", doc=f"singleton K{i + 1} of Table 3.2", eq="eq. 3.24, Table 3.2",
                    allowed=POSITIVE) for i, k in enumerate(AKF1D_K_DEFAULTS)))

    def _check(self) -> None:
        v = self.values
        if v["fft_length"] < v["window"]:
            raise ValueError(f"{self.name}: fft_length ({v['fft_length']}) must be >= window ({v['window']})")

    def stream(self, rate_hz: float | None = None, dt: float | None = None, q0: Any = None, frame: str = "ENU"):
        """Per-sample AKF1D through the buffered fallback of :class:`AttitudeFilter`: the fuzzy scale of
        R needs the packets so far (eqs. 3.19-3.22); equal to the batch, O(n) per sample."""
        return AttitudeFilter.stream(self, rate_hz, dt, q0, frame)

    def fis(self) -> SugenoFIS:
        """The fuzzy system of eq. 3.24 with this filter's options."""
        v = self.values
        return akf1d_fis(v["f_range_hz"], v["acc_range_g"], [v[f"K{i + 1}"] for i in range(5)])

    def disturbances(self, rec: Recording) -> tuple[np.ndarray, np.ndarray]:
        """``(f_hat Hz, alpha_hat g)`` (N,) each: eqs. 3.19-3.21 on ``gyr[:, 1]`` and eq. 3.22."""
        from objectives.attitude import disturbance as dis

        v = self.values
        vib = dis.vibration_frequency(rec.gyr, rec.dt, v["window"], v["fft_length"], v["omega_thr"],
                                      axis=1, f_thr=v["f_thr"])
        ext = dis.external_acceleration(rec.acc, v["window"])
        return vib, ext

    def scale(self, vib: np.ndarray, ext: np.ndarray) -> np.ndarray:
        """Fuzzy scale ``K_k`` (N,) of R (eq. 3.24) for the measures ``f_hat`` (Hz) and ``alpha_hat`` (g).

        The measures are piecewise constant (one value per packet), so the system is evaluated only
        where an input changes and held in between (the same numbers as evaluating every sample).
        """
        X = np.stack([np.asarray(vib, dtype=float), np.asarray(ext, dtype=float)], axis=1)
        n = X.shape[0]
        if n == 0:
            return np.empty(0)
        starts = np.flatnonzero(np.concatenate([[True], np.any(X[1:] != X[:-1], axis=1)]))
        vals = np.atleast_1d(self.fis()(X[starts]))
        return np.ascontiguousarray(np.repeat(vals, np.diff(np.append(starts, n))))

    def _run(self, rec: Recording, q0: np.ndarray) -> FilterResult:
        vib, ext = self._disturbances(rec)
        K = self.scale(vib, ext)
        th, b = self._kf(rec, q0, K)
        return FilterResult(quat_from_tilt(th), rec.frame,
                            {"angle": th, "gyr_bias": b, "K": K, "vib_freq_hz": vib, "ext_acc": ext})


# --- Mahony1D / Madgwick1D -----------------------------------------------------------------------
def _tilt_start(q0: np.ndarray, frame: str, q_frame: str) -> np.ndarray:
    """The Mahony/Madgwick 1-D kernels' start state (3,): the half-angle quaternion ``(cos, sin)`` of the tilt
    of ``q0`` (in ``q_frame``) in ``frame``'s convention (:func:`tilt_from_quat`,
    :func:`~objectives.attitude.filters._kf1d_kernels.tilt_state`) and a zero integral."""
    state = np.empty(3)
    tilt_state(tilt_from_quat(q0, frame, q_frame), state)
    return state


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
        gy, ax, az = _inputs(rec)
        th = np.empty(rec.n)
        b = np.empty(rec.n)
        v = self.values
        setup = self.kernel_setup(rec.dt, False, q0, rec.frame)
        th[0], b[0] = tilt_from_quat(q0, rec.frame, self.working_frame), 0.0
        c = setup.coef
        mahony1d_kernel(gy, ax, az, _up_sign(rec.frame), c[1], c[2], c[0], setup.state, bool(v["exact_step"]), th, b)
        return FilterResult(quat_from_tilt(th), rec.frame, {"angle": th, "gyr_bias": b})

    def kernel_setup(self, dt: float, use_mag: bool, q0: np.ndarray, frame: str, g_ref: float = G_SI) -> KernelSetup:
        """The kernel's gains ``(Ts, Kp, Ki)`` (it takes them as scalars) and start state (:func:`_tilt_start`);
        ``use_mag`` and ``g_ref`` do not enter."""
        return KernelSetup(np.array([dt, self.values["Kp"], self.values["Ki"]], dtype=np.float64),
                           _tilt_start(q0, frame, self.working_frame))

    def stream(self, rate_hz: float | None = None, dt: float | None = None, q0: Any = None, frame: str = "ENU"):
        """O(1) per-sample filter (the kernel carries the quaternion and integral in ``state``)."""
        return _TiltStream(self, rate_hz, dt, q0, frame)

    def _pair_step(self, state, gy, ax, az, up_sign, coef, th, b) -> None:
        mahony1d_kernel(gy, ax, az, up_sign, coef[1], coef[2], coef[0], state, bool(self.values["exact_step"]), th, b)


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
        gy, ax, az = _inputs(rec)
        th = np.empty(rec.n)
        v = self.values
        setup = self.kernel_setup(rec.dt, False, q0, rec.frame)
        th[0] = tilt_from_quat(q0, rec.frame, self.working_frame)
        c = setup.coef
        madgwick1d_kernel(gy, ax, az, _up_sign(rec.frame), c[1], c[0], setup.state, bool(v["exact_step"]), th)
        return FilterResult(quat_from_tilt(th), rec.frame, {"angle": th})

    def kernel_setup(self, dt: float, use_mag: bool, q0: np.ndarray, frame: str, g_ref: float = G_SI) -> KernelSetup:
        """The kernel's gains ``(Ts, beta)`` (it takes them as scalars) and start state (:func:`_tilt_start`);
        ``use_mag`` and ``g_ref`` do not enter."""
        return KernelSetup(np.array([dt, self.values["beta"]], dtype=np.float64),
                           _tilt_start(q0, frame, self.working_frame))

    stream = Mahony1D.stream

    def _pair_step(self, state, gy, ax, az, up_sign, coef, th, b) -> None:
        madgwick1d_kernel(gy, ax, az, up_sign, coef[1], coef[0], state, bool(self.values["exact_step"]), th)


class _TiltStream(StateStream):
    """Per-sample 1-D filter: sample 0 is the initial angle, every later sample one kernel call on the
    (previous, current) pair, as the batch kernels do at that sample. Output in the stream's frame."""

    def _init_state(self, q0: np.ndarray) -> np.ndarray:
        f = self.filter
        self.output_frame = self.frame  # the 1-D filters work in the recording's own frame
        self._up = _up_sign(self.frame)
        self._pair = (np.zeros(2), np.zeros(2), np.zeros(2))
        self._th = np.empty(2)
        self._b = np.empty(2)
        self._one = np.ones(1)
        self._theta = tilt_from_quat(q0, self.frame, f.working_frame)
        setup = f.kernel_setup(self.dt, False, q0, self.frame)
        self._coef = setup.coef
        return setup.state

    def _step(self, state, gyr, acc, mag):
        f = self.filter
        gy, ax, az = self._pair
        gy[0], ax[0], az[0] = gy[1], ax[1], az[1]
        gy[1], ax[1], az[1] = gyr[0, 1], acc[0, 0], acc[0, 2]
        if self.n > 0:
            if isinstance(f, KF1D):
                kf1d_kernel(gy, ax, az, self._up, self._coef, self._one, state, 1, self._th, self._b)
            else:
                f._pair_step(state, gy, ax, az, self._up, self._coef, self._th, self._b)
            self._theta = self._th[1]
        return quat_from_tilt(np.array([self._theta]))[0]

