"""Validating wrapper of the loop kernels: allocate the outputs, pick the LTI or nonlinear kernel."""

from __future__ import annotations

from typing import Any

import numpy as np

from objectives.control.plants.kernels import OPT_SIZE, _loop_lti, _loop_nl, _rk4

__all__ = ["simulate_loop", "DIVERGENCE_LIMIT"]

#: |state| beyond which the loop counts as diverged
DIVERGENCE_LIMIT = 1e9


def _opt(plant: Any, kind: int, real: Any) -> np.ndarray:
    opt = np.zeros(OPT_SIZE)
    opt[:] = [kind, plant.delay_n, plant.output, max(plant.inner_output, 0), real.u_min, real.u_max,
              real.rate_limit * plant.period_s, real.u_quantum, real.y_quantum, DIVERGENCE_LIMIT]
    return opt


def simulate_loop(plant: Any, kind: int, cp: np.ndarray, sig: np.ndarray, real: Any) -> dict[str, Any]:
    """Run the loop; ``sig`` (N, 2 + n_meas) holds r, load and the noise. Returns t, y, u, x (N rows;
    rows after a divergence are zero), status (0 ok, 2 diverged, 3 wrong dx shape) and n_done."""
    n_steps = sig.shape[0]
    cp = np.ascontiguousarray(cp, dtype=np.float64)
    opt = _opt(plant, kind, real)
    n = plant.n_states
    if hasattr(plant, "Ad"):
        m = plant.n_inputs
        y, u, x = np.zeros((n_steps, plant.n_outputs)), np.zeros((n_steps, m)), np.zeros((n_steps, n))
        status, done = _loop_lti(plant.Ad, plant.Bd, plant.Cd, plant.Dd, plant.x0, sig, cp, opt, y, u, x)
    else:
        m = plant.n_inputs
        y, u, x = np.zeros((n_steps, plant.n_outputs)), np.zeros((n_steps, m)), np.zeros((n_steps, n))
        loop, rk4 = (_loop_nl, _rk4) if plant.compiled else (_loop_nl.py_func, getattr(plant, "advance", _rk4.py_func))
        if hasattr(plant, "reset"):  # an FMU: back to its initial state for every simulation
            plant.reset()
        status, done = loop(plant.fn, rk4, plant.params, plant.x0, sig, cp, opt, plant.period_s, plant.n_sub,
                            plant.outputs, m, y, u, x)
    return {"t": np.arange(n_steps) * plant.period_s, "y": y, "u": u, "x": x, "status": int(status),
            "n_done": int(done)}
