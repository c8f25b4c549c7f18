"""Parameters of the wheeled mobile pendulum: the robot (thesis Table 2.1) and its sensors (Table 1.1).

Both are frozen dataclasses validated at construction, built from YAML mappings with
:meth:`from_dict` (unknown keys are errors), and turned into the float64 coefficient arrays the
kernels of :mod:`objectives.control.plants.wmp.model` read (:meth:`WMPParams.coeffs`, :meth:`SensorParams.coeffs`).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from dataclasses import asdict, dataclass, fields, replace
from typing import Any

import numpy as np

__all__ = ["WMPParams", "SensorParams", "N_COEFFS"]

# indices into the plant coefficient array built by WMPParams.coeffs()
_L, _R, _MW, _D, _MB, _JA, _JB, _RES, _IND, _KE, _KM, _JR, _FM, _FW, _K, _G, _JW, _UMAX = range(18)
N_COEFFS = 18


def _check_finite(obj, names: Iterable[str], positive: Iterable[str], what: str) -> None:
    """Raise ``ValueError`` naming every field of ``obj`` in ``names`` that is not a finite number, or
    is <= 0 (those in ``positive``) or < 0 (the others)."""
    positive = set(positive)
    problems = []
    for name in names:
        v = getattr(obj, name)
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
            problems.append(f"{name}={v!r} is not a finite number")
        elif name in positive and v <= 0:
            problems.append(f"{name}={v!r} must be > 0")
        elif v < 0:
            problems.append(f"{name}={v!r} must be >= 0")
    if problems:
        raise ValueError(f"invalid {what} parameters: " + "; ".join(problems))


def _from_mapping(cls, overrides: Mapping[str, Any] | None, what: str):
    """``cls()`` with ``overrides`` applied; unknown keys are a ``ValueError`` listing the known ones."""
    overrides = dict(overrides or {})
    known = {f.name for f in fields(cls)}
    unknown = sorted(set(overrides) - known)
    if unknown:
        raise ValueError(f"unknown {what} parameter(s) {unknown}; known: {sorted(known)}")
    return replace(cls(), **overrides)


@dataclass(frozen=True)
class WMPParams:
    """Physical parameters of the robot (thesis Table 2.1), SI units.

    Table 2.1 gives l, r, d in mm, masses in g, inertias in g mm^2, k_E in mV s, k_M in mN m / A,
    frictions in mN m s; they are converted here (g mm^2 = 1e-9 kg m^2).

    Attributes
    ----------
    l_m : distance of the IB centre of mass from the wheel axis (8.36 mm).
    r_m : wheel radius (31.5 mm).
    m_w_kg : mass of one wheel (31.5 g).
    d_m : distance between the wheels (177 mm).
    m_b_kg : mass of the inner body (360.4 g).
    J_A_kgm2, J_B_kgm2 : IB moments of inertia about the wheel axis A and the vertical axis B.
    R_ohm, L_H : rotor resistance (2.3 Ohm) and inductance (26 uH).
    k_E_Vs : back-EMF constant (2.05 mV s / rad); k_M_NmA : torque constant (2.05 mN m / A).
    J_r_kgm2 : rotor inertia (12 g mm^2). gear : gear ratio k (64).
    f_m_Nms, f_w_Nms : viscous friction at the motors (0.021 mN m s) and the wheels (0.18 mN m s).
    g_ms2 : gravitational acceleration.
    J_w_kgm2 : wheel inertia about its axle; ``None`` means a uniform disc m_w r^2 / 2 (the
        appendix's 3/2 m_w r^2 term).
    u_max_V : voltage saturation of the drivers (3.3 V supply, section 1.3).
    """

    l_m: float = 8.36e-3
    r_m: float = 31.5e-3
    m_w_kg: float = 31.5e-3
    d_m: float = 0.177
    m_b_kg: float = 0.3604
    J_A_kgm2: float = 81367e-9
    J_B_kgm2: float = 574620e-9
    R_ohm: float = 2.3
    L_H: float = 26e-6
    k_E_Vs: float = 2.05e-3
    k_M_NmA: float = 2.05e-3
    J_r_kgm2: float = 12e-9
    f_m_Nms: float = 0.021e-3
    f_w_Nms: float = 0.18e-3
    gear: float = 64.0
    g_ms2: float = 9.81
    J_w_kgm2: float | None = None
    u_max_V: float = 3.3

    def __post_init__(self) -> None:
        self.validate()

    def validate(self) -> None:
        """Raise ``ValueError`` naming every parameter outside its physical range."""
        positive = ["r_m", "m_w_kg", "d_m", "m_b_kg", "J_A_kgm2", "J_B_kgm2", "R_ohm", "L_H", "gear", "u_max_V"]
        nonneg = ["l_m", "k_E_Vs", "k_M_NmA", "J_r_kgm2", "f_m_Nms", "f_w_Nms", "g_ms2"]
        optional = ["J_w_kgm2"] if self.J_w_kgm2 is not None else []  # None: a uniform disc
        _check_finite(self, positive + nonneg + optional, positive, "WMP")

    @classmethod
    def from_dict(cls, overrides: Mapping[str, Any] | None) -> WMPParams:
        """Table 2.1 values with ``overrides`` (a YAML mapping) applied; unknown keys are errors."""
        return _from_mapping(cls, overrides, "WMP")

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)

    @property
    def wheel_inertia(self) -> float:
        return 0.5 * self.m_w_kg * self.r_m**2 if self.J_w_kgm2 is None else float(self.J_w_kgm2)

    def coeffs(self) -> np.ndarray:
        """The (18,) float64 coefficient array the kernels read."""
        c = np.empty(N_COEFFS)
        c[_L], c[_R], c[_MW], c[_D], c[_MB] = self.l_m, self.r_m, self.m_w_kg, self.d_m, self.m_b_kg
        c[_JA], c[_JB], c[_RES], c[_IND] = self.J_A_kgm2, self.J_B_kgm2, self.R_ohm, self.L_H
        c[_KE], c[_KM], c[_JR], c[_FM], c[_FW] = (
            self.k_E_Vs,
            self.k_M_NmA,
            self.J_r_kgm2,
            self.f_m_Nms,
            self.f_w_Nms,
        )
        c[_K], c[_G], c[_JW], c[_UMAX] = self.gear, self.g_ms2, self.wheel_inertia, self.u_max_V
        return c


@dataclass(frozen=True)
class SensorParams:
    """Sampled sensors of the robot (thesis Table 1.1) and the theta3 Kalman filter (eq. 2.20).

    Resolutions follow Table 1.1; noise levels are not given in the thesis and are documented
    choices from the sensors' data sheets. Set every ``*_noise`` and ``*_lsb`` to 0 for ideal sensors.

    Attributes
    ----------
    Ts_s : controller and sensor period (0.01 s, section 2.2.2.2).
    gyro_noise_dps, gyro_lsb_dps, gyro_bias_dps : L3G4200D rate noise (std, deg/s; 0.03 dps/sqrt(Hz)
        over ~100 Hz -> 0.3), resolution (16 bit at +-500 dps -> 17.5 mdps) and constant bias.
    acc_noise_g, acc_lsb_g : LIS331DL noise (std per axis, g) and resolution (8 bit over +-2 g).
    enc_lsb_deg : encoder resolution at the wheel, relative to the IB (PA2-100, 400 counts per motor
        revolution through the 64:1 gear -> 0.0141 deg, Table 1.1).
    cur_noise_A, cur_lsb_A : INA198 current measurement noise (std) and resolution. Table 1.1 gives
        0.8 mV per step of the sensor output; with the assumed 0.1 Ohm shunt and gain 50 that is 0.16 mA.
    pwm_bits : resolution of the PWM drive (10 bit, section 2.2.3.1); 0 disables quantisation.
    kf_q_theta, kf_q_bias, kf_r : process noise variances of theta3 (rad^2) and gyro bias
        (rad^2/s^2) per step and the accelerometer-angle variance (rad^2) of the KF of eq. 2.20. The
        thesis derived them offline from measurements it does not list; these are our choices.
    """

    Ts_s: float = 0.01
    gyro_noise_dps: float = 0.3
    gyro_lsb_dps: float = 0.0175
    gyro_bias_dps: float = 0.0
    acc_noise_g: float = 0.01
    acc_lsb_g: float = 4.0 / 256.0
    enc_lsb_deg: float = 0.0141
    cur_noise_A: float = 0.002
    cur_lsb_A: float = 1.6e-4
    pwm_bits: int = 10
    kf_q_theta: float = 1e-6
    kf_q_bias: float = 1e-9
    kf_r: float = 3e-3

    def __post_init__(self) -> None:
        _check_finite(self, [f.name for f in fields(self)], ("Ts_s", "kf_r"), "sensor")

    @classmethod
    def from_dict(cls, overrides: Mapping[str, Any] | None) -> SensorParams:
        """Default sensors with ``overrides`` (a YAML mapping) applied; unknown keys are errors."""
        return _from_mapping(cls, overrides, "sensor")

    @classmethod
    def ideal(cls, Ts_s: float = 0.01) -> SensorParams:
        """Noise-free, unquantised sensors (the KF still runs)."""
        return cls(Ts_s, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0)

    def coeffs(self, u_max_V: float) -> np.ndarray:
        """The (13,) float64 array the kernel reads (SI units: rad, m/s^2, A, V)."""
        d2r = math.pi / 180.0
        g0 = 9.80665
        u_lsb = 2.0 * u_max_V / (2**self.pwm_bits - 1) if self.pwm_bits > 0 else 0.0
        return np.array(
            [
                self.gyro_noise_dps * d2r,
                self.gyro_lsb_dps * d2r,
                self.gyro_bias_dps * d2r,
                self.acc_noise_g * g0,
                self.acc_lsb_g * g0,
                self.enc_lsb_deg * d2r,
                self.cur_noise_A,
                self.cur_lsb_A,
                self.kf_q_theta,
                self.kf_q_bias,
                self.kf_r,
                self.Ts_s,
                u_lsb,
            ]
        )

