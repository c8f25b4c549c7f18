"""AMIGO and SIMC tuning rules (objectives/control/plants/rules.py) against the literature's formulas
and examples, and the FOTD fit against an exact FOTD response."""

import numpy as np
import pytest

from objectives.control.plants.rules import FOTD, amigo_pid, fit_fotd, half_rule, series_to_ideal, simc_pid


def test_amigo_pid_formula():
    """Åström & Hägglund (2004), AMIGO PID: K Kp = 0.2 + 0.45 T/L, Ti = L (0.4 L + 0.8 T)/(L + 0.1 T),
    Td = 0.5 L T / (0.3 L + T); for Kp = 1, T = L = 1: 0.65, 1.2/1.1, 0.5/1.3."""
    K, Ti, Td = amigo_pid(FOTD(1.0, 1.0, 1.0))
    assert (K, Ti, Td) == pytest.approx((0.65, 1.2 / 1.1, 0.5 / 1.3))
    K2, Ti2, Td2 = amigo_pid(FOTD(2.0, 4.0, 0.5))  # K scales with 1/Kp; times scale with T and L
    assert K2 == pytest.approx((0.2 + 0.45 * 8) / 2) and Ti2 == pytest.approx(0.5 * (0.2 + 3.2) / (0.5 + 0.4))
    assert Td2 == pytest.approx(0.5 * 0.5 * 4 / (0.15 + 4))


def test_simc_half_rule_skogestad_example():
    """Skogestad (2003), the half rule on 1/((s+1)(0.2s+1)(0.04s+1)(0.008s+1)) to SOPDT: tau1 = 1,
    tau2 = 0.2 + 0.04/2 = 0.22, theta = 0.04/2 + 0.008 = 0.028; SIMC PID with tau_c = theta:
    Kc = tau1 / (k 2 theta) = 17.86, tauI = min(tau1, 8 theta) = 0.224, tauD = tau2 = 0.22."""
    k, t1, t2, th = half_rule(1.0, [1.0, 0.2, 0.04, 0.008], 0.0)
    assert (k, t1, t2, th) == pytest.approx((1.0, 1.0, 0.22, 0.028))
    kc, ti, td = simc_pid(k, t1, t2, th)
    assert (kc, ti, td) == pytest.approx((1 / 0.056, 0.224, 0.22))
    # an inverse-response time constant counts as delay
    assert half_rule(1.0, [1.0], 0.5, [0.3])[3] == pytest.approx(0.8)


def test_series_to_ideal_is_the_same_controller():
    kc, ti, td = 2.0, 1.5, 0.4
    K, Ti, Td = series_to_ideal(kc, ti, td)
    for s in (0.1j, 1.0j, 3.0 + 2.0j):
        assert kc * (1 + 1 / (ti * s)) * (1 + td * s) == pytest.approx(K * (1 + 1 / (Ti * s) + Td * s))


def test_fotd_fit_recovers_an_exact_fotd():
    t = np.linspace(0, 30, 3001)
    y = np.where(t > 0.7, 2.0 * (1 - np.exp(-(t - 0.7) / 3.0)), 0.0)
    m = fit_fotd(t, y)
    assert (m.K, m.T, m.L) == pytest.approx((2.0, 3.0, 0.7), rel=1e-3)
