"""Numba kernels of the generic closed loop: controller step, actuator, LTI and nonlinear plant loops.

Private pure functions over contiguous float64 arrays (STYLE 12); the public wrappers in
:mod:`objectives.control.plants.simulate` validate and allocate. One period ``k`` of both loops:

1. measure: ``meas = (x if state feedback else y) + noise[k]``, rounded to the sensor quantum;
2. control: ``u_c = controller(r[k], meas)`` (the kinds below);
3. actuate: saturation ``[u_min, u_max]``, rate limit ``du_max`` per period, quantum; the load
   disturbance ``load[k]`` is added to input 0; the result enters the input-delay line;
4. advance the plant one period with the delayed input held (ZOH): the discrete recursion
   ``x <- Ad x + Bd u`` (LTI), or ``n_sub`` RK4 steps of ``dx/dt = f(x, u, t, params)`` (nonlinear).

Controller kinds (:mod:`objectives.control.kinds`, the one kind space) and their coefficient arrays ``cp``:

- ``KIND_OPEN`` (0): ``u0 = r`` (open loop, for tests and step responses);
- ``KIND_PID`` (1): one PID block (``PID_COEFFS`` floats, below) on output ``out_idx``;
- ``KIND_CASCADE`` (2): outer PID block on ``out_idx`` whose output is the set point of the inner
  block on ``inner_idx``;
- ``KIND_SF`` (3): ``[n, m, K (m*n, row-major), Nbar (m), u_min, u_max]``: ``u = clip(-K x + Nbar r)``.

PID block ``[K, b, c, ki, ad, bd, aw, kt, u_min, u_max]`` (Åström & Murray, Feedback Systems,
2nd ed., section 11.5): ``v = K (b r - y) + I + D`` with ``D <- ad D + bd ((c r - y) - (c r - y)_prev)``
(backward difference of the filtered derivative, ``ad = Td / (Td + N h)``, ``bd = K Td N / (Td + N h)``),
``u = clip(v, u_min, u_max)`` and ``I <- I + ki (r - y)`` (``ki = K h / Ti``) plus, by ``aw``:
0 nothing, 1 back-calculation ``+ kt (u - v)`` (``kt = h / Tt``), 2 clamping (no integration while
saturated in the direction of the error). Block state ``[I, D, yc_prev, started]``.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from objectives.control.kinds import KIND_CASCADE, KIND_OPEN, KIND_PID, KIND_SF

__all__ = ["PID_COEFFS", "PID_STATE", "STATUS_OK", "STATUS_DIVERGED", "OPT_SIZE"]

PID_COEFFS = 10
PID_STATE = 4
STATUS_OK, STATUS_DIVERGED = 0, 2
#: ``opt`` layout: kind, delay_n, out_idx, inner_idx, u_min, u_max, du_max, u_quantum, y_quantum, div_limit
OPT_SIZE = 10


@njit
def _pid_block(cp, o, cs, s, r, y):
    """One PID block: coefficients ``cp[o:o+10]``, state ``cs[s:s+4]``; returns the limited output."""
    k, b, c, ki, ad, bd, aw, kt, umin, umax = (cp[o], cp[o + 1], cp[o + 2], cp[o + 3], cp[o + 4], cp[o + 5],
                                               cp[o + 6], cp[o + 7], cp[o + 8], cp[o + 9])
    yc = c * r - y
    if cs[s + 3] == 0.0:
        cs[s + 2] = yc
        cs[s + 3] = 1.0
    cs[s + 1] = ad * cs[s + 1] + bd * (yc - cs[s + 2])
    cs[s + 2] = yc
    v = k * (b * r - y) + cs[s] + cs[s + 1]
    u = min(max(v, umin), umax)
    e = r - y
    if aw == 1.0:
        cs[s] += ki * e + kt * (u - v)
    elif aw == 2.0:
        if not ((v > umax and e > 0.0) or (v < umin and e < 0.0)):
            cs[s] += ki * e
    else:
        cs[s] += ki * e
    return u


@njit
def _control(kind, cp, cs, r, meas, out_idx, inner_idx, u):
    """Controller output into ``u`` (length m) from reference ``r`` and the measurement vector."""
    u[:] = 0.0
    if kind == KIND_OPEN:
        u[0] = r
    elif kind == KIND_PID:
        u[0] = _pid_block(cp, 0, cs, 0, r, meas[out_idx])
    elif kind == KIND_CASCADE:
        r_in = _pid_block(cp, 0, cs, 0, r, meas[out_idx])
        u[0] = _pid_block(cp, PID_COEFFS, cs, PID_STATE, r_in, meas[inner_idx])
    else:
        n, m = int(cp[0]), int(cp[1])
        umin, umax = cp[2 + m * n + m], cp[3 + m * n + m]
        for i in range(m):
            acc = cp[2 + m * n + i] * r
            for j in range(n):
                acc -= cp[2 + i * n + j] * meas[j]
            u[i] = min(max(acc, umin), umax)


@njit
def _actuate(u, u_prev, opt, load):
    """Actuator: saturation, rate limit, quantum (in place on ``u``); the load adds to input 0."""
    umin, umax, dmax, q = opt[4], opt[5], opt[6], opt[7]
    for i in range(u.size):
        v = min(max(u[i], umin), umax)
        if dmax > 0.0:
            v = min(max(v, u_prev[i] - dmax), u_prev[i] + dmax)
        if q > 0.0:
            v = q * math.floor(v / q + 0.5)
        u[i] = v
        u_prev[i] = v
    u[0] += load


@njit
def _measure(v, noise_row, q, out):
    for i in range(v.size):
        w = v[i] + noise_row[i]
        out[i] = q * math.floor(w / q + 0.5) if q > 0.0 else w


@njit(cache=True, inline="always")
def _controller_period(k, fb, sig, cp, cs, opt, meas, u, u_prev, line, u_applied, u_out):
    """Steps 1-3 of period ``k`` (module docstring) from the feedback ``fb`` (state or output): ``u``
    and ``u_out[k]`` (without the load) are set, ``u_applied`` is the input of the delay line's end."""
    kind, delay = int(opt[0]), int(opt[1])
    _measure(fb, sig[k, 2:], opt[8], meas)
    _control(kind, cp, cs, sig[k, 0], meas, int(opt[2]), int(opt[3]), u)
    _actuate(u, u_prev, opt, sig[k, 1])
    u_out[k] = u
    u_out[k, 0] -= sig[k, 1]
    line[k % (delay + 1)] = u
    u_applied[:] = line[(k + 1) % (delay + 1)] if delay > 0 else u
    if delay > 0 and k < delay:
        u_applied[:] = 0.0


@njit(cache=True, inline="always")
def _loop_buffers(opt, n, m, p):
    """The work arrays of both loops for ``n`` states, ``m`` inputs, ``p`` outputs: ``y`` (p),
    ``meas`` (n with state feedback, else p), ``u``, ``u_prev``, ``u_applied`` (m, zero), the
    input-delay ``line`` (delay + 1, m, zero) and the controller state ``cs`` (zero)."""
    delay = int(opt[1])
    meas = np.empty(n if int(opt[0]) == KIND_SF else p)
    return (np.empty(p), meas, np.zeros(m), np.zeros(m), np.zeros(m), np.zeros((delay + 1, m)),
            np.zeros(2 * PID_STATE))


@njit(cache=True, inline="always")
def _diverged(xn, div):
    """Whether any state is not below ``div`` in magnitude (NaN included)."""
    bad = False
    for i in range(xn.size):
        if not (abs(xn[i]) < div):
            bad = True
    return bad


@njit(cache=True, inline="always")
def _affine(a, x, b, u, out):
    """``out = a x + b u`` (summed in the order of ``x`` then ``u``)."""
    for i in range(out.size):
        acc = 0.0
        for j in range(x.size):
            acc += a[i, j] * x[j]
        for j in range(u.size):
            acc += b[i, j] * u[j]
        out[i] = acc


@njit(cache=True)
def _loop_lti(ad, bd, cd, dd, x0, sig, cp, opt, y_out, u_out, x_out):
    """The closed loop with a discrete LTI plant; ``sig`` (N, 2 + n_meas): r, load, noise.

    Writes y_out (N, p), u_out (N, m: the actuator output before the load), x_out (N, n); returns
    (status, periods done).
    """
    n_steps = sig.shape[0]
    n, m, p = ad.shape[0], bd.shape[1], cd.shape[0]
    kind, div = int(opt[0]), opt[9]
    x = x0.copy()
    xn = np.empty(n)
    y, meas, u, u_prev, u_applied, line, cs = _loop_buffers(opt, n, m, p)
    for k in range(n_steps):
        _affine(cd, x, dd, u_applied, y)
        y_out[k] = y
        x_out[k] = x
        _controller_period(k, x if kind == KIND_SF else y, sig, cp, cs, opt, meas, u, u_prev, line, u_applied, u_out)
        _affine(ad, x, bd, u_applied, xn)
        if _diverged(xn, div):
            return STATUS_DIVERGED, k + 1
        x[:] = xn
    return STATUS_OK, n_steps


@njit
def _rk4(f, x, u, t, params, h, n_sub):
    for _ in range(n_sub):
        k1 = f(x, u, t, params)
        k2 = f(x + 0.5 * h * k1, u, t + 0.5 * h, params)
        k3 = f(x + 0.5 * h * k2, u, t + 0.5 * h, params)
        k4 = f(x + h * k3, u, t + h, params)
        x = x + (h / 6.0) * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
        t += h
    return x


@njit
def _loop_nl(f, rk4, params, x0, sig, cp, opt, period, n_sub, y_idx, n_in, y_out, u_out, x_out):
    """The closed loop with ``dx/dt = f(x, u, t, params)`` (RK4, ``n_sub`` steps per period), outputs
    ``y = x[y_idx]``; otherwise as :func:`_loop_lti` (no feedthrough). ``rk4`` is :func:`_rk4` (its
    ``py_func`` for the pure-Python run of a function numba cannot compile). Not cached: compiled per ``f``."""
    n_steps = sig.shape[0]
    n, p = x0.size, y_idx.size
    kind, div = int(opt[0]), opt[9]
    x = x0.copy()
    y, meas, u, u_prev, u_applied, line, cs = _loop_buffers(opt, n, n_in, p)
    h = period / n_sub
    for k in range(n_steps):
        for i in range(p):
            y[i] = x[y_idx[i]]
        y_out[k] = y
        x_out[k] = x
        _controller_period(k, x if kind == KIND_SF else y, sig, cp, cs, opt, meas, u, u_prev, line, u_applied, u_out)
        xn = rk4(f, x, u_applied.copy(), k * period, params, h, n_sub)
        if xn.size != n:
            return 3, k + 1
        if _diverged(xn, div):
            return STATUS_DIVERGED, k + 1
        x = xn
    return STATUS_OK, n_steps
