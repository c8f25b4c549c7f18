"""The thesis's tilt Kalman filter (KF1D, eqs. 3.9-3.13) and its fuzzy-adaptive form (AKF1D, eqs. 3.19-3.24)
with their C ports; see :mod:`objectives.attitude.filters.kf1d` for the equations and conventions."""

from __future__ import annotations

import functools
import math
from typing import Any, ClassVar

import numpy as np

from objectives.attitude.cexport.port import CField, CMember, CPort, RenderContext, c_array, c_literal
from objectives.attitude.data.recording import Recording
from objectives.attitude.filters.base import G_SI, AttitudeFilter, FilterResult, KernelSetup
from objectives.attitude.filters.kf1d.kernel import C, X, change_starts, kf1d_kernel
from objectives.attitude.filters.kf1d.population import POPULATION
from objectives.attitude.filters.kf1d.tilt import TiltStream, quat_from_tilt, tilt_from_quat, tilt_inputs, up_sign
from objectives.fuzzy import TRAP, TRI, SugenoFIS, grid_rules
from objectives.params import NONNEG, POSITIVE, Interval, Param, ParamSet

__all__ = ["KF1D", "AKF1D", "akf1d_fis", "AKF1D_K_DEFAULTS"]

#: the constant scale of R of the KF (the AKF's is per sample)
_ONE = np.ones(1)


# --- the C ports -----------------------------------------------------------------------------------
def _c_fields(v: dict, ctx: RenderContext) -> list[CField]:
    """The up sign of the export's frame (the tilt's convention) and the start orientation's magnetometer use."""
    return [CField("real", "up_sign", -1.0 if ctx.frame == "NED" else 1.0, "+1: z-up earth frame (ENU), -1: NED"),
            CField("int", "use_mag", True, "the start orientation uses the magnetometer when given")]


#: the state of the KF's C (named members: the kernel's state layout X, then what the port carries)
_TILT_MEMBERS = (
    CMember("real", "th", (), "tilt angle about y, rad"),
    CMember("real", "b", (), "gyro bias, rad/s"),
    CMember("real", "p00", (), "covariance"),
    CMember("real", "p01"),
    CMember("real", "p11"),
    CMember("real", "prev_gyr", (), "the previous gyro sample about y, rad/s"),
    CMember("real", "dt_s"),
    CMember("int", "started"),
    CMember("params", "p"),
)


def _akf_members(flt: Any) -> tuple[CMember, ...]:
    """The AKF's state: the KF's, then the current packet (``window`` samples) and the held fuzzy scale."""
    return (*_TILT_MEMBERS,
            CMember("real", "buf", (int(flt.values["window"]),), "the gyro about y of the current packet"),
            CMember("real", "ext_sum", (), "its sum of external acceleration, g"),
            CMember("int", "nbuf", (), "samples in it"),
            CMember("real", "kscale", (), "the held fuzzy scale K of R (eq. 3.24)"),
            CMember("real", "vib_hz", (), "the last packet's vibration frequency, Hz"),
            CMember("real", "ext_g", (), "and external acceleration, g"))


def _akf_defines(flt: Any, ctx: RenderContext) -> list[str]:
    """The AKF1D's packet and fuzzy constants (static tables: its sets, 9 rules and singletons)."""
    v = flt.values
    fis = flt.fis()
    f = np.fft.rfftfreq(int(v["fft_length"]), 1.0 / ctx.rate_hz)
    n_bins = int(np.searchsorted(f, float(v["f_thr"]) * (1 + 1e-12), side="right"))
    return ["#define AKF 1", f"#define AKF_WINDOW {int(v['window'])}", f"#define AKF_NFFT {int(v['fft_length'])}",
            f"#define AKF_NBINS {n_bins} /* bins up to f_thr = {v['f_thr']!r} Hz at {ctx.rate_hz:g} Hz */",
            f"#define AKF_DF {c_literal(f[1] - f[0], 'real')}",
            f"#define AKF_OMEGA_THR {c_literal(v['omega_thr'], 'real')}",
            f"#define AKF_NRULES {fis.rules.shape[0]}", f"#define AKF_MF_INIT {c_array(fis.mf_params)}",
            f"#define AKF_KIND_INIT {c_array(fis.mf_kind, 'int')}",
            f"#define AKF_RULES_INIT {c_array(fis.rules, 'int')}",
            f"#define AKF_CONS_INIT {c_array(fis.consequents)}", *_akf_twiddles(int(v["fft_length"]))]


def _akf_twiddles(n_fft: int) -> list[str]:
    """sin(2 pi r / n_fft), r = 0 .. n_fft / 4: the DFT's twiddle factors by quarter-wave symmetry, so that
    the packet's DFT needs no sine or cosine per term (n_fft not a multiple of 4: computed per term)."""
    if n_fft % 4:
        return []
    tw = [math.sin(2.0 * math.pi * r / n_fft) for r in range(n_fft // 4 + 1)]
    return [f"#define AKF_TW_INIT {{{', '.join(c_literal(x, 'real') for x in tw)}}}"]


#: the KF's C port (port.c, ported from kernel.py; sine/cosine and angle wrapping of the shared parts); the tilt
#: about y in the frame of the export's recordings
KF_PORT = CPort((__package__, "port.c"), ("trig.c", "angle.c"), _TILT_MEMBERS, fields=_c_fields,
                defines=lambda flt, ctx: ["#define AKF 0"], tilt=True)
#: the AKF's: the same port with its packet and fuzzy system compiled in (their options are constants there)
AKF_PORT = CPort((__package__, "port.c"), ("trig.c", "angle.c"), _akf_members, fields=_c_fields,
                 defines=_akf_defines, tilt=True,
                 skip=("window", "fft_length", "f_thr", "omega_thr", "f_range_hz", "acc_range_g",
                       *(f"K{i + 1}" for i in range(5))))


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
    decl: ClassVar[ParamSet] = ParamSet("kf1d", _kf_noise(
        (0.008, 0.45), (7e-9, 2e-6), (1e-13, 2e-8), (0.05, 5e-7, 5e-9),
        "accelerometer-angle noise variance R (eq. 3.17)") + _P0_OPTIONS)
    population = POPULATION
    c_port = KF_PORT

    def kernel_setup(self, dt: float, use_mag: bool, q0: np.ndarray, frame: str, g_ref: float = G_SI) -> KernelSetup:
        """The kernel's ``(Ts, q00, q11, rho)`` (eqs. 3.11, 3.17; layout ``C`` of
        :mod:`~objectives.attitude.filters.kf1d.kernel`) and start state ``(theta_0, 0, P_0)`` (layout ``X``),
        ``theta_0`` the tilt of ``q0`` in ``frame``'s convention (:func:`~.tilt.tilt_from_quat`); ``use_mag`` and
        ``g_ref`` do not enter."""
        v = self.values
        theta0 = tilt_from_quat(q0, frame, self.working_frame)
        return KernelSetup(C.pack(DT=dt, Q00=v["q00"], Q11=v["q11"], RHO=v["rho"]),
                           X.pack(THETA=theta0, BIAS=0.0, P00=v["p0_theta"], P01=0.0, P11=v["p0_bias"]))

    def _kf(self, rec: Recording, q0: np.ndarray, kscale: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        gy, ax, az = tilt_inputs(rec)
        th = np.empty(rec.n)
        b = np.empty(rec.n)
        setup = self.kernel_setup(rec.dt, False, q0, rec.frame)
        kf1d_kernel(gy, ax, az, up_sign(rec.frame), setup.coef, kscale, setup.state, 1, th, b)
        return th, b

    def _run(self, rec: Recording, q0: np.ndarray) -> FilterResult:
        th, b = self._kf(rec, q0, np.ones(1))
        return FilterResult(quat_from_tilt(th), rec.frame, {"angle": th, "gyr_bias": b})

    def stream(self, rate_hz: float | None = None, dt: float | None = None, q0: Any = None, frame: str = "ENU"):
        """O(1) per-sample tilt KF (the kernel carries angle, bias and covariance in ``state``)."""
        return TiltStream(self, rate_hz, dt, q0, frame)

    def _pair_step(self, state, gy, ax, az, up, coef, th, b) -> None:
        """One step of the stream (:class:`~.tilt.TiltStream`) on the (previous, current) pair."""
        kf1d_kernel(gy, ax, az, up, coef, _ONE, state, 1, th, b)


# --- AKF1D ---------------------------------------------------------------------------------------
#: K1..K5 defaults (not in the text; see the module docstring)
AKF1D_K_DEFAULTS = (1.0, 3.0, 10.0, 30.0, 100.0)


def akf1d_fis(f_range_hz: float, acc_range_g: float, kappa: Any) -> SugenoFIS:
    """The 9-rule Sugeno system of thesis Table 3.2 / eq. 3.24 with the sets of the module docstring.

    Inputs ``(f_hat Hz, alpha_hat g)``; rule ``(i_f, i_a)`` -> ``K_{1 + i_f + i_a}``. The system is built once
    per set of values (a candidate's run over several recordings, or a stream, builds it once): treat it as
    read-only.
    """
    kappa = np.asarray(kappa, dtype=float).reshape(-1)
    if kappa.shape != (5,):
        raise ValueError(f"akf1d: need the 5 singletons K1..K5, got {kappa.size}")
    return _akf1d_fis(float(f_range_hz), float(acc_range_g), tuple(kappa.tolist()))


@functools.lru_cache(maxsize=64)
def _akf1d_fis(f_range_hz: float, acc_range_g: float, kappa: tuple[float, ...]) -> SugenoFIS:
    params = np.zeros((2, 3, 4))
    kinds = np.array([[TRAP, TRI, TRAP], [TRAP, TRI, TRAP]])
    for j, r in enumerate((f_range_hz, acc_range_g)):
        h = 0.5 * r
        params[j, 0] = (-np.inf, -np.inf, 0.0, h)
        params[j, 1] = (0.0, h, r, 0.0)
        params[j, 2] = (h, r, np.inf, np.inf)
    rules = grid_rules([3, 3])
    return SugenoFIS(kinds, params, rules, np.asarray(kappa)[rules.sum(axis=1)], and_op="min")


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
    c_port = AKF_PORT  # no population kernel (the fuzzy scale of R): serial only
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
        vib = np.ascontiguousarray(vib, dtype=float)
        ext = np.ascontiguousarray(ext, dtype=float)
        n = vib.shape[0]
        if n == 0:
            return np.empty(0)
        starts = change_starts(vib, ext)
        vals = np.atleast_1d(self.fis()(np.stack([vib[starts], ext[starts]], axis=1)))
        return np.ascontiguousarray(np.repeat(vals, np.diff(np.append(starts, n))))

    def _run(self, rec: Recording, q0: np.ndarray) -> FilterResult:
        vib, ext = self._disturbances(rec)
        K = self.scale(vib, ext)
        th, b = self._kf(rec, q0, K)
        return FilterResult(quat_from_tilt(th), rec.frame,
                            {"angle": th, "gyr_bias": b, "K": K, "vib_freq_hz": vib, "ext_acc": ext})
