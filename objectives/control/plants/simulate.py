"""Validating wrapper of the loop kernels: the actuator and sensor options, the outputs allocated, and the
plant's own ``run_loop`` (each ``Plant`` variant runs its kernel: :mod:`objectives.control.plants.base`)."""

from __future__ import annotations

from typing import Any

import numpy as np

from objectives.control.plants.kernels import OPT_SIZE

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
    y = np.zeros((n_steps, plant.n_outputs))
    u = np.zeros((n_steps, plant.n_inputs))
    x = np.zeros((n_steps, plant.n_states))
    status, done = plant.run_loop(sig, cp, opt, y, u, x)
    return {"t": np.arange(n_steps) * plant.period_s, "y": y, "u": u, "x": x, "status": int(status),
            "n_done": int(done)}
