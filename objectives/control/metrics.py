"""Control-quality measures of thesis sections 2.2.3.2 and 2.3.3.2.

- SAE, SSE (eq. 2.34) and STAE, STSE (eq. 2.35, discrete time-weighted with t_k = k Ts, k = 1..N);
- the overall value of a measure as log10 of the product over the errors (eq. 2.36);
- the MAE-weighted cost F of eq. 2.39.

Units used for the errors (a reconstruction: the thesis does not state them, but these make the
magnitudes of its Table 2.5 and F_init = 0.1049 consistent): e_nu in m/s, e_xi in rad/s, e_omega3 in
deg/s, I_A in A.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

__all__ = [
    "sae",
    "sse",
    "stae",
    "stse",
    "log10_product",
    "mae_weighted_cost",
    "DEFAULT_COST_WEIGHTS",
    "error_integrals",
]

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
    """F of eq. 2.39: the fourth root of the weighted product of mean absolute errors.

    F = (MAE(e_nu)^alpha1 MAE(e_xi)^alpha2 MAE(e_omega3)^beta mean(I_A^2)^gamma)^(1/4), each mean over
    the N samples (the thesis's "L" is the measurement length). Signals (N,) in the units of the
    module docstring; weights default to :data:`DEFAULT_COST_WEIGHTS`.
    """
    w = dict(DEFAULT_COST_WEIGHTS)
    if weights:
        unknown = sorted(set(weights) - set(w))
        if unknown:
            raise ValueError(f"unknown cost weight(s) {unknown}; known: {sorted(w)}")
        w.update({k: float(v) for k, v in weights.items()})
    sig = [_e(e_nu), _e(e_xi), _e(e_omega3), _e(i_avg)]
    n = sig[0].size
    if n == 0 or any(s.size != n for s in sig):
        raise ValueError(f"signals must be non-empty and of equal length, got {[s.size for s in sig]}")
    terms = [np.mean(np.abs(sig[0])), np.mean(np.abs(sig[1])), np.mean(np.abs(sig[2])), np.mean(sig[3] ** 2)]
    expo = [w["alpha1"], w["alpha2"], w["beta"], w["gamma"]]
    return float(np.prod([t**a for t, a in zip(terms, expo)]) ** 0.25)
