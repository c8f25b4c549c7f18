"""PID tuning rules from the literature, for comparison and as starting points: AMIGO and SIMC.

- FOTD model ``K e^{-Ls} / (T s + 1)`` of a plant's unit step response, by one of two named fits
  (:data:`FITS`), since the rules' results depend on it:

  - ``lsq``: least squares of the FOTD step response against the samples (:func:`fit_fotd_lsq`);
  - ``area``: the method of areas (Åström & Hägglund, PID Controllers: Theory, Design and Tuning, 2nd ed.,
    ISA 1995, ch. 2): ``A0 = int (K - y) dt`` gives the average residence time ``Tar = A0 / K = T + L``,
    ``A1 = int_0^Tar y dt`` gives ``T = e A1 / K``, and ``L = Tar - T`` (:func:`fit_fotd_area`); exact for
    a FOTD process, and it weighs the whole response rather than its fit in time.
- AMIGO PID (Åström & Hägglund, "Revisiting the Ziegler-Nichols step response method for PID
  control", J. Process Control 14 (2004) 635-650; also Advanced PID Control, ISA 2006, section 7.6):
  ``K = (0.2 + 0.45 T / L) / Kp``, ``Ti = L (0.4 L + 0.8 T) / (L + 0.1 T)``, ``Td = 0.5 L T / (0.3 L + T)``.
  The rule is the approximation of an M-constrained design at M = 1.4 on the FOTD model and has no form for
  another robustness; its knob here (:func:`amigo_detuned`) is a factor ``alpha <= 1`` on the gain ``K``
  (``Ti``, ``Td`` kept), which scales the loop transfer function and so lowers Ms towards 1.
- SIMC (Skogestad, "Simple analytic rules for model reduction and PID controller tuning",
  J. Process Control 13 (2003) 291-309): the half rule reduces the plant to
  ``k e^{-theta s} / ((tau1 s + 1)(tau2 s + 1))`` (:func:`half_rule`), then the series PID (eq. (4)-(6))
  ``Kc = tau1 / (k (tau_c + theta))``, ``tauI = min(tau1, 4 (tau_c + theta))``, ``tauD = tau2``; its knob is
  the closed-loop time constant ``tau_c``, ``theta`` for the paper's recommended tight tuning and larger for
  more robustness; :func:`series_to_ideal` converts to the ideal form ``Kc (1 + tauD / tauI)``,
  ``tauI + tauD``, ``tauI tauD / (tauI + tauD)``.

:func:`detune_to_ms` moves a rule's knob from its published value towards robustness until the loop's Ms
(any callable: the sampled loop's exact Ms for the generic loop) meets a limit, so that a rule always gives a
baseline that meets the same robustness requirement as a tuned controller.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

__all__ = ["FOTD", "FITS", "fit_fotd", "fit_fotd_lsq", "fit_fotd_area", "amigo_pid", "half_rule", "simc_pid",
           "series_to_ideal", "amigo_detuned", "simc_detuned", "detune_to_ms", "Detuned"]

#: the FOTD fits by name
FITS = ("lsq", "area")


@dataclass(frozen=True)
class FOTD:
    """``K e^{-L s} / (T s + 1)``: static gain, time constant T (s), delay L (s)."""

    K: float
    T: float
    L: float


def fit_fotd_lsq(t: np.ndarray, y: np.ndarray) -> FOTD:
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


def fit_fotd_area(t: np.ndarray, y: np.ndarray, gain: float | None = None) -> FOTD:
    """The method of areas (module docstring) on a unit step response ``y(t)`` sampled at the uniform times
    ``t`` from 0 (trapezoids); ``gain`` is the static gain when known (default: the last sample). A response
    whose areas give ``T <= 0`` or ``L < 0`` (far from a FOTD, e.g. oscillatory) is clipped to ``L = 0`` or a
    ``T`` of one sample, as the method defines no model there."""
    t, y = np.asarray(t, dtype=float), np.asarray(y, dtype=float)
    k = float(y[-1] if gain is None else gain)
    if not (math.isfinite(k) and k > 0):
        raise ValueError(f"the area method needs a positive static gain, got {k!r}")
    a0 = float(np.trapezoid(k - y, t))
    tar = a0 / k
    if not tar > 0:
        raise ValueError(f"the area method needs a positive average residence time, got {tar!r} s")
    m = t <= tar
    a1 = float(np.trapezoid(y[m], t[m]))
    if t[m][-1] < tar:  # the last piece up to Tar, interpolated
        i = int(np.flatnonzero(m)[-1])
        yt = y[i] + (y[i + 1] - y[i]) * (tar - t[i]) / (t[i + 1] - t[i])
        a1 += 0.5 * (y[i] + yt) * (tar - t[i])
    tau = max(math.e * a1 / k, float(t[1] - t[0]))
    return FOTD(k, min(tau, tar), max(tar - tau, 0.0))


def fit_fotd(t: np.ndarray, y: np.ndarray, method: str = "lsq") -> FOTD:
    """FOTD model of a unit step response by the fit ``method`` (:data:`FITS`)."""
    if method == "lsq":
        return fit_fotd_lsq(t, y)
    if method == "area":
        return fit_fotd_area(t, y)
    raise ValueError(f"unknown FOTD fit {method!r}; allowed: {list(FITS)}")


def amigo_pid(m: FOTD) -> tuple[float, float, float]:
    """AMIGO ``(K, Ti, Td)`` of the ideal-form PID for the FOTD model ``m`` (needs ``L > 0``)."""
    if not m.L > 0:
        raise ValueError(f"AMIGO needs a FOTD model with a delay L > 0, got L = {m.L!r} s")
    K = (0.2 + 0.45 * m.T / m.L) / m.K
    Ti = m.L * (0.4 * m.L + 0.8 * m.T) / (m.L + 0.1 * m.T)
    Td = 0.5 * m.L * m.T / (0.3 * m.L + m.T)
    return K, Ti, Td


def amigo_detuned(m: FOTD, alpha: float) -> tuple[float, float, float]:
    """AMIGO with its gain scaled by ``alpha`` (1: the rule)."""
    K, Ti, Td = amigo_pid(m)
    return alpha * K, Ti, Td


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


def simc_detuned(sopdt: tuple[float, float, float, float], lam: float) -> tuple[float, float, float]:
    """SIMC in ideal form with ``tau_c = lam * theta`` (1: the tight tuning) for ``(k, tau1, tau2, theta)``."""
    k, tau1, tau2, theta = sopdt
    if not theta > 0:
        raise ValueError(f"SIMC with tau_c = theta needs a delay theta > 0, got {theta!r} s")
    return series_to_ideal(*simc_pid(k, tau1, tau2, theta, lam * theta))


def series_to_ideal(kc: float, ti: float, td: float) -> tuple[float, float, float]:
    """Series (interacting) PID ``Kc (1 + 1/(tauI s)) (1 + tauD s)`` to the ideal form ``(K, Ti, Td)``."""
    f = 1 + td / ti
    return kc * f, ti * f, td / f if td > 0 else 0.0


@dataclass(frozen=True)
class Detuned:
    """A rule moved along its knob: ``pid`` ``(K, Ti, Td)``, the ``knob`` value (1: the rule as published),
    its ``ms``, and whether the rule as published already met the limit (``detuned`` False)."""

    pid: tuple[float, float, float]
    knob: float
    ms: float
    detuned: bool


def detune_to_ms(family: Callable[[float], tuple[float, float, float]], ms_of: Callable[[tuple], float],
                 ms_max: float, toward: str, span: float = 1e4, rel_tol: float = 1e-7) -> Detuned:
    """The rule ``family(knob)`` (knob 1: as published) at the knob value nearest 1 whose ``ms_of`` is at most
    ``ms_max`` (an unstable loop's Ms is inf).

    ``toward`` is ``"down"`` (the knob is a factor that falls, e.g. AMIGO's gain factor) or ``"up"`` (it
    rises, e.g. SIMC's ``tau_c / theta``): a log scan of 60 steps over ``span`` finds the first value that
    meets the limit, then a bisection on ``log knob`` the boundary to ``rel_tol``. ``ValueError`` when no
    value over the span meets it."""
    def ok(knob: float) -> tuple[bool, float]:
        ms = ms_of(family(knob))
        return bool(ms <= ms_max), ms

    met, ms = ok(1.0)
    if met:
        return Detuned(family(1.0), 1.0, ms, False)
    sign = -1.0 if toward == "down" else 1.0
    if toward not in ("down", "up"):
        raise ValueError(f"toward must be 'down' or 'up', got {toward!r}")
    steps = np.exp(sign * np.linspace(0.0, math.log(span), 61))[1:]
    bad, good = 0.0, None
    for s in steps:
        met, ms = ok(float(s))
        if met:
            good = math.log(float(s))
            break
        bad = math.log(float(s))
    if good is None:
        raise ValueError(f"no knob value within a factor {span:g} of the rule meets Ms <= {ms_max:g}")
    while abs(good - bad) > rel_tol:
        mid = 0.5 * (good + bad)
        met, _ = ok(math.exp(mid))
        good, bad = (mid, bad) if met else (good, mid)
    knob = math.exp(good)
    return Detuned(family(knob), knob, ms_of(family(knob)), True)
