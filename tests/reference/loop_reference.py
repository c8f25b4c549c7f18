"""Slow plain-Python references of the generic loop kernels (objectives/control/plants/kernels.py).

Written from the equations in the kernels' docstring, sample by sample, without sharing code with
them: a discrete LTI plant with input delay, a 2-DOF PID with back-calculation or clamping, the
actuator (saturation, rate limit, quantum) and the load at plant input 0.
"""

import math

import numpy as np


def pid_reference(K, Ti, Td, N, b, c, h, aw="backcalc", Tt=None, umin=-math.inf, umax=math.inf):
    """A PID as a closure ``step(r, y) -> u`` (Åström & Murray, Feedback Systems, section 11.5)."""
    st = {"I": 0.0, "D": 0.0, "yc": None}
    if Tt is None:
        Tt = math.sqrt(Ti * Td) if Td > 0 else Ti / 2

    def step(r, y):
        yc = c * r - y
        if st["yc"] is None:
            st["yc"] = yc
        if Td > 0:
            st["D"] = Td / (Td + N * h) * st["D"] + K * Td * N / (Td + N * h) * (yc - st["yc"])
        st["yc"] = yc
        v = K * (b * r - y) + st["I"] + st["D"]
        u = min(max(v, umin), umax)
        e = r - y
        ki = 0.0 if math.isinf(Ti) else K * h / Ti
        if aw == "backcalc":
            st["I"] += ki * e + h / Tt * (u - v)
        elif aw == "clamp":
            if not ((v > umax and e > 0) or (v < umin and e < 0)):
                st["I"] += ki * e
        else:
            st["I"] += ki * e
        return u

    return step


def loop_reference(Ad, Bd, Cd, Dd, delay_n, x0, r, load, noise, controller, umin=-1e300, umax=1e300,
                   rate=0.0, uq=0.0, yq=0.0, out=0):
    """Closed loop of a discrete plant and ``controller(r, y_meas) -> u`` (SISO): returns y (N, p), u (N,)."""
    n = len(r)
    x = np.array(x0, dtype=float)
    u_prev = 0.0
    applied_prev = 0.0
    history = []  # actuator outputs plus load, in time order
    ys, us = [], []
    for k in range(n):
        y = Cd @ x + Dd[:, 0] * applied_prev
        ys.append(y.copy())
        meas = y + noise[k]
        if yq > 0:
            meas = yq * np.floor(meas / yq + 0.5)
        uc = controller(r[k], meas[out])
        v = min(max(uc, umin), umax)
        if rate > 0:
            v = min(max(v, u_prev - rate), u_prev + rate)
        if uq > 0:
            v = uq * math.floor(v / uq + 0.5)
        u_prev = v
        us.append(v)
        history.append(v + load[k])
        applied = history[k - delay_n] if k >= delay_n else 0.0
        x = Ad @ x + Bd[:, 0] * applied
        applied_prev = applied
    return np.array(ys), np.array(us)
