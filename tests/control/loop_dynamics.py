"""Dynamics functions for tests/control/test_loop_plants.py and test_loop_configs.py."""

import fractions

import numpy as np


def linear(x, u, t, params):
    out = np.empty(2)
    out[0] = x[1]
    out[1] = -2.0 * x[0] - 0.5 * x[1] + u[0]
    return out


def linear_py(x, u, t, params):
    """The same as :func:`linear` with a Python object numba cannot compile (a Fraction)."""
    k = float(fractions.Fraction(2, 1))
    return np.array([x[1], -k * x[0] - 0.5 * x[1] + u[0]])


def wrong_shape(x, u, t, params):
    return np.zeros(3)


def returns_nan(x, u, t, params):
    return np.array([x[1], np.nan])


def stiff(x, u, t, params):
    return np.array([-params.lam * x[0] + u[0]])
