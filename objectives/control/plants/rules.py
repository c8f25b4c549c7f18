"""PID tuning rules from the literature, for comparison and as starting points: AMIGO and SIMC.

- FOTD model ``K e^{-Ls} / (T s + 1)``: :func:`fit_fotd` fits one to a plant's unit step response
  by least squares (as the AMIGO rules assume a FOTD model of the process).
- AMIGO PID (Åström & Hägglund, "Revisiting the Ziegler-Nichols step response method for PID
  control", J. Process Control 14 (2004) 635-650; also Advanced PID Control, ISA 2006, section 7.6):
  ``K = (0.2 + 0.45 T / L) / Kp``, ``Ti = L (0.4 L + 0.8 T) / (L + 0.1 T)``, ``Td = 0.5 L T / (0.3 L + T)``.
- SIMC (Skogestad, "Simple analytic rules for model reduction and PID controller tuning",
  J. Process Control 13 (2003) 291-309): the half rule reduces the plant to
  ``k e^{-theta s} / ((tau1 s + 1)(tau2 s + 1))`` (:func:`half_rule`), then the series PID
  ``Kc = tau1 / (k (tau_c + theta))``, ``tauI = min(tau1, 4 (tau_c + theta))``, ``tauD = tau2`` with
  ``tau_c = theta`` (eq. (4) with the paper's recommended tight tuning); :func:`series_to_ideal` converts it to
  the ideal form ``Kc (1 + tauD / tauI)``, ``tauI + tauD``, ``tauI tauD / (tauI + tauD)``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["FOTD", "fit_fotd", "amigo_pid", "half_rule", "simc_pid", "series_to_ideal"]


@dataclass(frozen=True)
class FOTD:
    """``K e^{-L s} / (T s + 1)``: static gain, time constant T (s), delay L (s)."""

    K: float
    T: float
    L: float


def fit_fotd(t: np.ndarray, y: np.ndarray) -> FOTD:
    """Least-squares FOTD fit to a unit step response ``y(t)`` (the plant's own delay included)."""
    from scipy.optimize import least_squares

    k0 = float(y[-1])
    i63 = int(np.argmax(y >= 0.632 * k0)) if k0 > 0 else len(t) // 2
    i10 = int(np.argmax(y >= 0.1 * k0)) if k0 > 0 else 0

    def model(p):
        k, tau, lag = p
        return np.where(t > lag, k * (1 - np.exp(-(t - lag) / tau)), 0.0)

    p0 = [k0, max(t[i63] - t[i10], 1e-3), max(t[i10] * 0.5, 0.0)]
    r = least_squares(lambda p: model(p) - y, p0, bounds=([1e-9, 1e-6, 0.0], [np.inf, np.inf, t[-1]]))
    return FOTD(*map(float, r.x))


def amigo_pid(m: FOTD) -> tuple[float, float, float]:
    """AMIGO ``(K, Ti, Td)`` of the ideal-form PID for the FOTD model ``m``."""
    K = (0.2 + 0.45 * m.T / m.L) / m.K
    Ti = m.L * (0.4 * m.L + 0.8 * m.T) / (m.L + 0.1 * m.T)
    Td = 0.5 * m.L * m.T / (0.3 * m.L + m.T)
    return K, Ti, Td


def half_rule(k: float, taus: list[float], theta: float,
              rhp_zeros: list[float] = ()) -> tuple[float, float, float, float]:
    """Skogestad's half rule to SOPDT: ``(k, tau1, tau2, theta)`` from lag time constants ``taus``, a delay
    and inverse-response (RHP zero) time constants (each added to the delay)."""
    ts = sorted((float(x) for x in taus), reverse=True) + [0.0, 0.0, 0.0]
    tau1, tau2, tau3 = ts[0], ts[1], ts[2]
    theta = theta + tau3 / 2 + sum(ts[3:]) + sum(rhp_zeros)
    tau2 = tau2 + tau3 / 2
    return k, tau1, tau2, theta


def simc_pid(k: float, tau1: float, tau2: float, theta: float,
             tau_c: float | None = None) -> tuple[float, float, float]:
    """SIMC series-form ``(Kc, tauI, tauD)``; ``tau_c`` defaults to ``theta`` (needs theta > 0)."""
    tc = theta if tau_c is None else tau_c
    kc = tau1 / (k * (tc + theta))
    ti = min(tau1, 4 * (tc + theta))
    return kc, ti, tau2


def series_to_ideal(kc: float, ti: float, td: float) -> tuple[float, float, float]:
    """Series (interacting) PID ``Kc (1 + 1/(tauI s)) (1 + tauD s)`` to the ideal form ``(K, Ti, Td)``."""
    f = 1 + td / ti
    return kc * f, ti * f, td / f if td > 0 else 0.0


