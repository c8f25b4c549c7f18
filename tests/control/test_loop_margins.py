"""Exact margins of the generic loop (objectives/control/plants/analysis.py): the grid's extrema and
crossings refined on the exact loop response.

References: python-control's ``stability_margins`` (for a discrete rational loop without delay it solves the
crossover polynomials, so its margins are exact), and a dense reference grid of 10^5 log-spaced frequencies
up to the Nyquist frequency, on which the refined Ms must never be exceeded by more than 1e-9 (the grid of 800
points alone misses sharp peaks by up to ~1e-2).
"""

from __future__ import annotations

import cmath
import math
import warnings

import control
import numpy as np
import pytest

from objectives.control.objective import ClosedLoopObjective
from objectives.control.plants.analysis import loop_response, margins


def _pid_loop(num, den, h, K, Ti, Td, delay_s=0.0):
    return ClosedLoopObjective.from_config({
        "kind": "closed_loop", "plant": {"tf": {"num": num, "den": den}, "delay_s": delay_s},
        "controller": "pid2dof", "period_s": h, "fixed": {"K": K, "Ti_s": Ti, "Td_s": Td, "N": 10.0},
        "scenario": {"duration_s": 5.0}})


def _python_control_loop(num, den, h, K, Ti, Td, N=10.0):
    ad, bd, ki = Td / (Td + N * h), K * Td * N / (Td + N * h), K * h / Ti
    z = control.tf([1, 0], [1], h)
    C = K + ki / (z - 1) + bd * (z - 1) / (z - ad)
    return C * control.sample_system(control.tf(num, den), h)


#: stable loops: (num, den, h, K, Ti, Td); the last is Åström and Hägglund's oscillatory plant (P9, w0 = 5)
_LOOPS = [([1.0], [1.0, 3.0, 3.0, 1.0], 0.05, 1.0, 2.0, 0.5),
          ([1.0], [1.0, 3.0, 3.0, 1.0], 0.05, 2.5, 1.5, 0.6),
          ([-1.0, 1.0], [1.0, 3.0, 3.0, 1.0], 0.05, 0.4, 1.5, 0.8),
          ([25.0], [1.0, 2.0, 26.0, 25.0], 0.01, 0.2379, 0.174, 0.1299)]


@pytest.mark.parametrize("loop", _LOOPS)
def test_margins_equal_python_controls_exact_ones(loop):
    """Phase and gain margins as python-control's polynomial solution, to 1e-5 deg and dB (its own roots of
    the high-order crossover polynomials at h = 0.01 are good to ~1e-6 in the margins, 2e-5 in frequency),
    and python-control's ``L`` evaluated at the refined crossovers is on the unit circle and the negative
    real axis to 1e-7 (the grid's linear interpolation was off by up to 3e-4 deg)."""
    num, den, h, K, Ti, Td = loop
    m = _pid_loop(num, den, h, K, Ti, Td).loop.loop_margins({})
    L = _python_control_loop(num, den, h, K, Ti, Td)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        gm, pm, _, w180, wc, _ = control.stability_margins(L)
    assert m["pm_deg"] == pytest.approx(pm, abs=1e-5) and m["wc_rad_s"] == pytest.approx(wc, rel=1e-4)
    Lc = complex(L(np.exp(1j * m["wc_rad_s"] * h)))
    assert abs(Lc) == pytest.approx(1.0, abs=1e-7)
    assert m["pm_deg"] == pytest.approx(180.0 + math.degrees(cmath.phase(Lc)), abs=1e-6)
    if math.isinf(gm):
        assert m["gm_db"] == math.inf
    else:
        assert m["gm_db"] == pytest.approx(20 * math.log10(gm), abs=1e-5)
        assert m["w180_rad_s"] == pytest.approx(w180, rel=1e-4)
        L180 = complex(L(np.exp(1j * m["w180_rad_s"] * h)))
        assert abs(math.degrees(cmath.phase(-L180))) < 1e-6
        assert m["gm_db"] == pytest.approx(-20 * math.log10(abs(L180)), abs=1e-7)


def test_delay_loop_margins_against_python_control():
    """With a delay of 30 periods (python-control's frequency-grid method, so its own error is the bound)."""
    h, K, Ti, Td = 0.01, 1.2, 2.0, 0.4
    m = _pid_loop([1.0], [1.0, 3.0, 3.0, 1.0], h, K, Ti, Td, delay_s=0.3).loop.loop_margins({})
    L = _python_control_loop([1.0], [1.0, 3.0, 3.0, 1.0], h, K, Ti, Td) * control.tf([1], [1, 0], h) ** 30
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        gm, pm, *_ = control.stability_margins(L)
    assert m["gm_db"] == pytest.approx(20 * math.log10(gm), abs=1e-3)
    assert m["pm_deg"] == pytest.approx(pm, abs=1e-2)


_PLANTS = {"(s+1)^-3": ([1.0], [1.0, 3.0, 3.0, 1.0], 0.0, 0.05, 3.0),
           "e^-s/(0.5s+1)": ([1.0], [0.5, 1.0], 1.0, 0.02, 1.5),
           "e^-s/(5s+1)^2": ([1.0], [25.0, 10.0, 1.0], 1.0, 0.05, 11.0),
           "oscillatory w0=10": ([100.0], [1.0, 3.0, 102.0, 100.0], 0.0, 0.01, 1.2)}


@pytest.mark.parametrize("name", sorted(_PLANTS))
def test_refined_ms_is_the_peak_of_a_dense_reference(name):
    """Random PIDs with Ms in (1, 3): the refined Ms is never below the 10^5-point reference (to 1e-9) nor
    above it by more than 1e-4 (the reference's own sampling); the 800-point grid alone falls short of the
    reference by more than 1e-4 on some of them."""
    num, den, delay, h, tar = _PLANTS[name]
    rng = np.random.default_rng(7)
    grid_short, n = 0.0, 0
    o = _pid_loop(num, den, h, 1.0, tar, 0.1 * tar, delay)
    lp = o.loop
    wn = math.pi / h
    wref = np.logspace(math.log10(1e-4 * wn), math.log10(wn), 100_000)
    pref = {"outputs": lp.plant.frequency_response(wref)}
    for _ in range(400):
        p = {"K": float(np.exp(rng.uniform(math.log(0.05), math.log(20.0)))),
             "Ti_s": float(tar * np.exp(rng.uniform(math.log(0.05), math.log(5.0)))),
             "Td_s": float(tar * np.exp(rng.uniform(math.log(0.002), math.log(1.0))))}
        m = lp.loop_margins(p)
        if not 1.0 < m["ms"] < 3.0:
            continue
        cp = lp.coeffs(p)
        ref = float(np.max(1.0 / np.abs(1.0 + loop_response(lp.ctrl, cp, lp.plant, wref, pref))))
        assert ref - 1e-9 <= m["ms"] <= ref + 1e-4, (p, m["ms"], ref)
        grid = margins(loop_response(lp.ctrl, cp, lp.plant, lp._omega, lp._pr), lp._omega)["ms"]
        grid_short = max(grid_short, ref - grid)
        n += 1
        if n == 25:
            break
    assert n == 25
    if name == "oscillatory w0=10":  # its sensitivity peaks are sharp: the grid alone misses them
        assert grid_short > 1e-4


def test_frequency_response_equals_python_control():
    """The batched plant response (one solve for all frequencies) is python-control's, with the delay."""
    o = _pid_loop([1.0, 2.0], [1.0, 3.0, 3.0, 1.0], 0.05, 1.0, 1.0, 0.1, delay_s=0.2)
    w = np.logspace(-2, math.log10(math.pi / 0.05), 50)
    z = np.exp(1j * w * 0.05)
    P = control.sample_system(control.tf([1.0, 2.0], [1.0, 3.0, 3.0, 1.0]), 0.05)
    want = np.array([complex(P(zi)) for zi in z]) * z ** -4
    assert np.allclose(o.loop.plant.frequency_response(w)[:, 0], want, rtol=1e-10, atol=1e-13)
