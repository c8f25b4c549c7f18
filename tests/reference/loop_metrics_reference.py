"""Slow plain-NumPy reference of the generic loop's statistics (objectives/control/plants/metrics.py).

Written from the definitions in that module's docstring with NumPy's reductions, sharing no code with
the kernel: the cost terms and signal means of one response, and the step, load and signal quantities.
"""

import math

import numpy as np


def cost_terms(t, e, u0, h):
    """IAE, ISE, ITAE, ITSE, effort and total variation of one response (e = r - y, u0 = input 0)."""
    ae = np.abs(e)
    du = np.diff(u0, prepend=u0[:1])
    return {"iae": float(ae.sum() * h), "ise": float((e * e).sum() * h), "itae": float((t * ae).sum() * h),
            "itse": float((t * e * e).sum() * h), "effort": float((u0 * u0).sum() * h), "tv": float(np.abs(du).sum())}


def signal_means(e, u0, y, x, h):
    """mean |.| of e, u0, du0/h, every output and every state."""
    du = np.diff(u0, prepend=u0[:1])
    out = {"e": float(np.mean(np.abs(e))), "u": float(np.mean(np.abs(u0))), "du": float(np.mean(np.abs(du / h)))}
    out.update({f"y{i}": float(np.mean(np.abs(y[:, i]))) for i in range(y.shape[1])})
    out.update({f"x{i}": float(np.mean(np.abs(x[:, i]))) for i in range(x.shape[1])})
    return out


def step_quantities(r, y, h, k0, k1):
    """Overshoot (%), 10-90 % rise time, 2 % settling time (s) and steady-state error of the step in [k0, k1)."""
    r0 = r[k0 - 1] if k0 > 0 else 0.0
    r1 = r[k1 - 1]
    yn = (y[k0:k1] - r0) / (r1 - r0)
    overshoot = max(0.0, float(np.max(yn)) - 1.0) * 100.0
    i10, i90 = np.flatnonzero(yn >= 0.1), np.flatnonzero(yn >= 0.9)
    rise = (i90[0] - i10[0]) * h if i10.size and i90.size else math.inf
    outside = np.flatnonzero(np.abs(yn - 1.0) > 0.02)
    settle = 0.0 if outside.size == 0 else (math.inf if outside[-1] == yn.size - 1 else (outside[-1] + 1) * h)
    return {"overshoot_pct": overshoot, "rise_time_s": float(rise), "settling_time_s": float(settle),
            "ss_error": float(abs(r1 - y[k1 - 1]))}


def load_peak(r, y, l0, l1):
    """max |r - y| over the load window [l0, l1)."""
    return float(np.max(np.abs(r[l0:l1] - y[l0:l1])))


def signal_quantities(u):
    """Peak |u| over every input and the standard deviation of input 0."""
    return {"peak_u": float(np.max(np.abs(u))), "u_std": float(np.std(u[:, 0]))}
