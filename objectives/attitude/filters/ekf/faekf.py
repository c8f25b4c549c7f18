"""The fuzzy-adaptive EKF (FAEKF; Odry et al. 2020, section 4, eqs. 23-31): the
:class:`~objectives.attitude.filters.ekf.EKF` with ``R_k = K_k R``, ``K_k`` the Sugeno system of
:mod:`objectives.attitude.filters.ekf.fuzzy` over the disturbance measures of :mod:`objectives.attitude.disturbance`.
See :mod:`objectives.attitude.filters.ekf.filter` for the equations and deviations."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from objectives.attitude.data.recording import Recording
from objectives.attitude.filters.base import AttitudeFilter, FilterResult
from objectives.attitude.filters.ekf.filter import EKF, EKF_DECL, ROBUST_DECL
from objectives.attitude.filters.ekf.fuzzy import (
    FUZZY_INPUTS,
    FUZZY_SETS,
    K_BOUNDS,
    K_DEFAULTS,
    SEARCHED_K,
    faekf_rules,
    fuzzy_decl,
    fuzzy_params,
    fuzzy_scale,
    mf_name,
)
from objectives.attitude.filters.ekf.population import FAEKF_POPULATION
from objectives.params import POSITIVE, Interval, Param, ParamSet
from tuner.space import Real, Space

__all__ = ["FAEKF", "Disturbances"]


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
    population = FAEKF_POPULATION
    decl: ClassVar[ParamSet] = ParamSet("faekf", (
        *EKF_DECL,
        *(Param(f"K{i + 1}", K_DEFAULTS[i], K_BOUNDS if f"K{i + 1}" in SEARCHED_K else None, "log", "1",
                f"singleton K{i + 1} of Table 1 (scale of R)", "eq. 31, Table 1", POSITIVE) for i in range(7)),
        *fuzzy_decl(),
        Param("window", 400, unit="samples", doc="L: window of eqs. 24, 26, 27", eq="eqs. 24, 26, 27",
              allowed=Interval(2.0), integer=True),
        Param("fft_length", 512, unit="samples", doc="L_FFT of eq. 23", eq="eq. 23", allowed=Interval(2.0),
              integer=True),
        Param("f_thr", 10.0, unit="Hz", doc="highest expected oscillation frequency (eq. 25)", eq="eq. 25",
              allowed=POSITIVE),
        Param("omega_thr", 0.26, unit="rad/s", doc="|Omega|_thr of eq. 25", eq="eq. 25", allowed=POSITIVE),
        Param("tune_fuzzy", False, doc="search the fuzzy sets too (FAEKF.space(tune_fuzzy=True))"),
        *ROBUST_DECL,
    ))

    @classmethod
    def space(cls, tune_fuzzy: bool | None = None) -> Space:
        """Default search space; with ``tune_fuzzy`` the 18 set parameters are searched too."""
        if not tune_fuzzy:
            return Space(cls.params)
        tunable = {p.name: p for p in fuzzy_params(tunable=True)}
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
                mf[j, s, 0] = self.values[mf_name(inp, name, "mean")]
                mf[j, s, 1] = self.values[mf_name(inp, name, "std")]
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
