"""Control-quality measures of thesis sections 2.2.3.2 and 2.3.3.2.

- SAE, SSE (eq. 2.34) and STAE, STSE (eq. 2.35, discrete time-weighted with t_k = k Ts, k = 1..N);
- the overall value of a measure as log10 of the product over the errors (eq. 2.36);
- the MAE-weighted cost F of eq. 2.39, in SI units;
- the rise time of a step response (Table 2.4's T_rise, the "reference achieved in less than 0.7 s"
  of section 2.3.4) and the settling time into a band (Table 2.4's T_5deg of the IB angle).

Units. The thesis states none for eqs. 2.34-2.39; two different sets are consistent with its numbers.

* Eq. 2.39 (F) takes every signal in SI: e_nu in m/s, e_xi and e_omega3 in rad/s, I_A in A. F is a
  product of powers of dimensional means, so its value depends on the units: with the Table 2.7
  initial parameters on our model, SI gives F = 0.112 on the thesis profile of 2 s steps (thesis
  0.1049; see docs/control-cost.md), while e_omega3 in deg/s multiplies F by
  (180/pi)^(1.6/4) = 5.07 and e_xi in deg/s by (180/pi)^(0.85/4) = 2.37, far from the thesis. SI
  is also the only choice that needs no unit conversion inside the simulation, where the thesis's
  model (eq. 2.12) is written.
* The error integrals of eqs. 2.34-2.36 are reported as in Table 2.5: e_nu in m/s, e_xi in rad/s
  and e_omega3 in deg/s. There SAE(e_omega3) = 4.27e3 over ~800 samples is a mean of ~5 deg/s, a
  plausible IB rate, whereas in rad/s it would be 5 rad/s = 290 deg/s on average; SAE(e_xi) = 128.7
  for the 0.5 / -1.2 rad/s yaw steps of section 2.2.3.1 is a lag of 0.38 s in rad/s, of 7 ms in
  deg/s (faster than the 0.9 s rise time of Table 2.4). These integrals are metrics only; they do
  not enter F.

Population kernels (``backend: threads``, objectives/control/batch.py) score a run inside numba with
:func:`_measures_kernel` and :func:`_weighted_cost_kernel` (sums by
:func:`objectives.batch_threads._pairwise_sum`), which add and
multiply in NumPy's order so that their values equal those of :func:`sae` ... :func:`mae_weighted_cost`
bit for bit (tests/control/test_metrics_kernel.py).
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
from numba import njit

from objectives.batch_threads import _pairwise_sum

__all__ = [
    "sae",
    "sse",
    "stae",
    "stse",
    "log10_product",
    "mae_weighted_cost",
    "DEFAULT_COST_WEIGHTS",
    "error_integrals",
    "first_step",
    "rise_time_s",
    "settling_time_s",
    "SETTLE_BAND_DEG",
]

#: Table 2.4's T_5deg: the band (deg) the IB angle settles into after a speed step
SETTLE_BAND_DEG = 5.0

#: alpha1 (speed), alpha2 (yaw rate), beta (IB rate), gamma (current) of eq. 2.39
DEFAULT_COST_WEIGHTS = {"alpha1": 1.4, "alpha2": 0.85, "beta": 1.6, "gamma": 0.4}


def _e(e) -> np.ndarray:
    e = np.asarray(e, dtype=float)
    if e.ndim != 1:
        raise ValueError(f"error signal must be one-dimensional, got shape {e.shape}")
    return e


def sae(e) -> float:
    """Sum of absolute errors, eq. 2.34."""
    return float(np.sum(np.abs(_e(e))))


def sse(e) -> float:
    """Sum of squared errors, eq. 2.34."""
    e = _e(e)
    return float(np.sum(e * e))


def stae(e, Ts: float) -> float:
    """Sum of time-weighted absolute errors sum_k k Ts |e_k| (k = 1..N), eq. 2.35."""
    e = _e(e)
    k = np.arange(1, e.size + 1)
    return float(np.sum(k * Ts * np.abs(e)))


def stse(e, Ts: float) -> float:
    """Sum of time-weighted squared errors sum_k k Ts e_k^2 (k = 1..N), eq. 2.35."""
    e = _e(e)
    k = np.arange(1, e.size + 1)
    return float(np.sum(k * Ts * e * e))


def log10_product(values) -> float:
    """log10 of the product of the per-error measures (eq. 2.36), computed as a sum of logs."""
    v = np.asarray(list(values), dtype=float)
    if np.any(v <= 0):
        return float("-inf")
    return float(np.sum(np.log10(v)))


def error_integrals(errors: Mapping[str, np.ndarray], Ts: float) -> dict[str, float]:
    """Every measure of every named error plus the eq. 2.36 overall values.

    Returns keys ``sae_<name>``, ``sse_<name>``, ``stae_<name>``, ``stse_<name>`` and
    ``sae_log10_prod`` etc.
    """
    out: dict[str, float] = {}
    for m, fn in (
        ("sae", sae),
        ("sse", sse),
        ("stae", lambda e: stae(e, Ts)),
        ("stse", lambda e: stse(e, Ts)),
    ):
        vals = []
        for name, e in errors.items():
            out[f"{m}_{name}"] = fn(e)
            vals.append(out[f"{m}_{name}"])
        out[f"{m}_log10_prod"] = log10_product(vals)
    return out


def mae_weighted_cost(e_nu, e_xi, e_omega3, i_avg, weights: Mapping[str, float] | None = None) -> float:
    """F of eq. 2.39: the fourth root of the weighted product of four mean absolute errors.

    F = (MAE(e_nu)^alpha1 MAE(e_xi)^alpha2 MAE(e_omega3)^beta mean(I_A^2)^gamma)^(1/4), each mean over
    the N samples (the thesis's "L" is the measurement length N: the sums run over j = 1..N).

    Parameters
    ----------
    e_nu : (N,) speed error nu_d - nu, m/s.
    e_xi : (N,) yaw-rate error xi_d - xi, rad/s.
    e_omega3 : (N,) IB-rate error -omega3, rad/s.
    i_avg : (N,) average motor current I_A = (I1 + I2) / 2, A.
    weights : overrides of :data:`DEFAULT_COST_WEIGHTS` (alpha1, alpha2, beta, gamma).

    Notes
    -----
    The value depends on the units (module docstring): with these SI units F at Table 2.7's initial
    parameters is 0.112 on our model with the thesis profile of 2 s steps (thesis: 0.1049). It also
    scales as ~1 / T^1.06 with the run length T (the means run over the whole run), which the thesis
    does not state (docs/control-cost.md section 3: 8.5 s instead of 8 s gives 0.1056).
    """
    expo = cost_exponents(weights).tolist()
    sig = [_e(e_nu), _e(e_xi), _e(e_omega3), _e(i_avg)]
    n = sig[0].size
    if n == 0 or any(s.size != n for s in sig):
        raise ValueError(f"signals must be non-empty and of equal length, got {[s.size for s in sig]}")
    terms = [np.mean(np.abs(sig[0])), np.mean(np.abs(sig[1])), np.mean(np.abs(sig[2])), np.mean(sig[3] ** 2)]
    return float(np.prod([t**a for t, a in zip(terms, expo)]) ** 0.25)


@njit(cache=False)  # compiled into the batch kernel that calls it (rule 2 of objectives.jit)
def _measures_kernel(e, ts, tmp, out):
    """SAE, SSE, STAE, STSE of ``e`` (eqs. 2.34-2.35) into ``out[0:4]``, equal to :func:`sae`, :func:`sse`,
    :func:`stae` and :func:`stse` bit for bit; ``tmp``: scratch of at least ``e``'s length."""
    n = e.shape[0]
    for i in range(n):
        tmp[i] = abs(e[i])
    out[0] = _pairwise_sum(tmp, 0, n)
    for i in range(n):
        tmp[i] = e[i] * e[i]
    out[1] = _pairwise_sum(tmp, 0, n)
    for i in range(n):
        tmp[i] = (i + 1) * ts * abs(e[i])  # k Ts |e_k|, multiplied left to right as NumPy does
    out[2] = _pairwise_sum(tmp, 0, n)
    for i in range(n):
        tmp[i] = (i + 1) * ts * e[i] * e[i]
    out[3] = _pairwise_sum(tmp, 0, n)


@njit
def _weighted_cost_kernel(terms, expo):
    """F of eq. 2.39 from its four means ``terms`` and exponents ``expo`` (alpha1, alpha2, beta, gamma),
    multiplied in :func:`mae_weighted_cost`'s order (equal to it bit for bit)."""
    prod = 1.0
    for i in range(4):
        prod *= terms[i] ** expo[i]
    return prod ** 0.25


def cost_exponents(weights: Mapping[str, float] | None = None) -> np.ndarray:
    """(4,) alpha1, alpha2, beta, gamma of eq. 2.39: :data:`DEFAULT_COST_WEIGHTS` with ``weights``' overrides."""
    w = dict(DEFAULT_COST_WEIGHTS)
    if weights:
        unknown = sorted(set(weights) - set(w))
        if unknown:
            raise ValueError(f"unknown cost weight(s) {unknown}; known: {sorted(w)}")
        w.update({k: float(v) for k, v in weights.items()})
    return np.array([w["alpha1"], w["alpha2"], w["beta"], w["gamma"]], dtype=float)


def first_step(ref) -> int | None:
    """Index of the first sample where ``ref`` differs from the sample before (from 0 before the start);
    None if it never steps."""
    steps = np.flatnonzero(np.diff(np.concatenate(([0.0], _e(ref)))) != 0)
    return int(steps[0]) if steps.size else None


def _step_window(y, ref, k0: int) -> tuple[np.ndarray, np.ndarray, int]:
    """``y`` and ``ref`` as float arrays and the end of the step window that starts at ``k0``: where ``ref``
    changes again, or the end (:func:`rise_time_s`, :func:`settling_time_s`)."""
    y, ref = _e(y), _e(ref)
    if y.size != ref.size:
        raise ValueError(f"y and ref must have equal length, got {y.size} and {ref.size}")
    if not (0 <= k0 < ref.size):
        raise ValueError(f"k0 must index the signals (0..{ref.size - 1}), got {k0}")
    change = np.flatnonzero(ref[k0:] != ref[k0])
    return y, ref, k0 + (int(change[0]) if change.size else ref.size - k0)


def rise_time_s(y, ref, Ts: float, k0: int, frac: float = 0.9) -> float:
    """Time from the reference step at sample ``k0`` until ``y`` first covers ``frac`` of the step.

    The step goes from ``ref[k0 - 1]`` (0 when ``k0 == 0``) to ``ref[k0]``; the search window ends
    where the reference changes again (or at the end). With ``frac = 0.9`` and a start at rest this
    is the 0-90 % rise time of the thesis's "the desired linear speed is achieved in 0.68 sec"
    (section 2.3.4). A first-order lag with time constant tau gives tau ln 10.

    Parameters
    ----------
    y, ref : (N,) response and reference, same units.
    Ts : sample period, s.
    k0 : index of the step (ref[k0] != ref[k0 - 1]).
    frac : fraction of the step to cover, in (0, 1].

    Returns
    -------
    (k - k0) Ts for the first k >= k0 in the window with (y_k - r0) / (r1 - r0) >= frac, or ``inf``
    if the response never gets there within the window.
    """
    if not (0.0 < frac <= 1.0) or not Ts > 0:
        raise ValueError(f"need 0 < frac <= 1 and Ts > 0, got frac={frac}, Ts={Ts}")
    y, ref, end = _step_window(y, ref, k0)
    r0 = float(ref[k0 - 1]) if k0 > 0 else 0.0
    r1 = float(ref[k0])
    if r1 == r0:
        raise ValueError(f"no reference step at sample {k0} (ref = {r1} before and after)")
    progress = (y[k0:end] - r0) / (r1 - r0)
    hit = np.flatnonzero(progress >= frac)
    return float(hit[0]) * Ts if hit.size else float("inf")


def settling_time_s(y, ref, Ts: float, k0: int, band: float) -> float:
    """Time from the reference step at sample ``k0`` until ``y`` stays within ``band`` of its value at
    the end of the step's window (Table 2.4's T_5deg with ``y`` the IB angle in deg and ``band = 5``).

    The window is that of :func:`rise_time_s`: from ``k0`` to where ``ref`` changes again (or the end).
    A first-order decay ``A exp(-t / tau)`` that has died out by the window's end settles at
    ``tau ln(A / band)``.

    Returns
    -------
    (k + 1 - k0) Ts for the last k in the window with ``|y_k - y_end| > band`` (0 if ``y`` never
    leaves the band). NaN in ``y`` counts as outside the band.
    """
    if not band > 0 or not Ts > 0:
        raise ValueError(f"need band > 0 and Ts > 0, got band={band}, Ts={Ts}")
    y, ref, end = _step_window(y, ref, k0)
    seg = y[k0:end]
    out = np.flatnonzero(~(np.abs(seg - seg[-1]) <= band))
    return float(out[-1] + 1) * Ts if out.size else 0.0
