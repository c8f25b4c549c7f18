"""The compiled closed loop of a MuJoCo plant: MuJoCo steps the physics, the loop reads, controls and writes.

One call simulates a whole scenario with no Python between two engine steps (:mod:`.capi`: MuJoCo's C
functions are called from the kernel). One controller period ``k`` (``n_sub`` engine steps of the model's
timestep):

1. ``mj_step1``: positions, velocities and the position/velocity sensors at the current state;
2. read the outputs ``y`` (joint positions/velocities, sensor values, body roll/pitch/yaw from ``xquat``)
   and the state ``x`` (``mj_differentiatePos`` from the operating point at the position dofs, the velocity
   dofs' velocities, the actuator activations, each from its operating value); a non-finite or huge state
   ends the run (diverged), an output beyond its limit ends it too (left its limits: a pendulum that fell);
3. measure: ``x`` (state feedback) or ``y`` (output feedback) plus the period's noise, through a delay
   line of ``delay`` periods (before the first ``delay`` periods the first measurement is held);
4. control (the kinds of :mod:`objectives.control.kinds`'s MuJoCo block, coefficient layouts below),
   saturate every input to its actuator's range and write it to ``ctrl``;
5. ``mj_step2`` completes the step with the new controls (``mj_step`` for RK4, which has no split step),
   then ``n_sub - 1`` more ``mj_step`` with the controls held.

Controller coefficients ``cp``:

- ``KIND_MJ_PID``: ``[L, (out, inp, PID block) x L]``: loop ``l`` drives input ``inp`` from output ``out``
  with one PID block of :mod:`objectives.control.plants.kernels` (10 coefficients, its own limits);
  the loops on one input add;
- ``KIND_MJ_LQR``: ``[n, m, p, K (m x n), Nx (n x p), Nu (m x p), u_op (m), ref (p), r_op (p)]``:
  ``u = u_op + Nu rd - K (x - Nx rd)`` with ``rd = r[ref] - r_op`` the referenced outputs' set points
  measured from their operating-point values (:mod:`.controllers`).

Private pure function over contiguous arrays (STYLE 12) behind :meth:`.model.MujocoPlant.run`; cached
under rule 3 of :mod:`objectives.jit` (it calls the PID block of another module, uncached, rule 2).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from objectives.control.kinds import KIND_MJ_LQR, KIND_MJ_PID
from objectives.control.plants.kernels import _pid_block
from objectives.jit import CACHE

__all__ = ["SRC_QPOS", "SRC_QVEL", "SRC_SENSOR", "SRC_ROLL", "SRC_PITCH", "SRC_YAW", "STATUS_OK", "STATUS_LIMIT",
           "STATUS_DIVERGED", "PID_WIDTH", "OPT_SIZE"]

#: where an output is read (first column of the plant's output table; the second is the address)
SRC_QPOS, SRC_QVEL, SRC_SENSOR, SRC_ROLL, SRC_PITCH, SRC_YAW = range(6)
STATUS_OK, STATUS_LIMIT, STATUS_DIVERGED = 0, 1, 2
#: one loop of ``KIND_MJ_PID``: output index, input index, the PID block's 10 coefficients
PID_WIDTH = 12
_PID_STATE = 4
#: ``opt`` layout: kind, n_sub, rk4 (1/0), delay (periods), divergence limit
OPT_SIZE = 5


@njit(inline="always")
def _euler(q, which):
    """Roll, pitch or yaw (ZYX angles, rad) of the unit quaternion ``q = (w, x, y, z)``."""
    w, x, y, z = q[0], q[1], q[2], q[3]
    if which == SRC_ROLL:
        return math.atan2(2.0 * (w * x + y * z), 1.0 - 2.0 * (x * x + y * y))
    if which == SRC_PITCH:
        return math.asin(min(max(2.0 * (w * y - z * x), -1.0), 1.0))
    return math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))


@njit(inline="always")
def _read_outputs(src, qpos, qvel, sdata, xquat, y):
    for i in range(src.shape[0]):
        kind, adr = src[i, 0], src[i, 1]
        if kind == SRC_QPOS:
            y[i] = qpos[adr]
        elif kind == SRC_QVEL:
            y[i] = qvel[adr]
        elif kind == SRC_SENSOR:
            y[i] = sdata[adr]
        else:
            y[i] = _euler(xquat[adr], kind)


@njit(inline="always")
def _read_state(diffpos, mp, qpos, qvel, act, pdofs, vdofs, qop, vop, aop, dq, x):
    """``x = (dq[pdofs], qvel[vdofs] - vop[vdofs], act - aop)``, ``dq`` MuJoCo's tangent-space difference."""
    diffpos(mp, dq.ctypes.data, 1.0, qop.ctypes.data, qpos.ctypes.data)
    n_p, n_v = pdofs.size, vdofs.size
    for i in range(n_p):
        x[i] = dq[pdofs[i]]
    for i in range(n_v):
        x[n_p + i] = qvel[vdofs[i]] - vop[vdofs[i]]
    for j in range(act.size):
        x[n_p + n_v + j] = act[j] - aop[j]


@njit(inline="always")
def _bad(v, div):
    for i in range(v.size):
        if not abs(v[i]) < div:
            return True
    return False


@njit(inline="always")
def _lqr(cp, r, meas, rd, u):
    n, m, p = int(cp[0]), int(cp[1]), int(cp[2])
    ok = 3
    onx = ok + m * n
    onu = onx + n * p
    oop = onu + m * p
    oref = oop + m
    orop = oref + p
    for j in range(p):
        rd[j] = r[int(cp[oref + j])] - cp[orop + j]
    for i in range(m):
        acc = cp[oop + i]
        for j in range(p):
            acc += cp[onu + i * p + j] * rd[j]
        for c in range(n):
            xt = meas[c]
            for j in range(p):
                xt -= cp[onx + c * p + j] * rd[j]
            acc -= cp[ok + i * n + c] * xt
        u[i] = acc


@njit(inline="always")
def _control(kind, cp, cs, r, meas, rd, u):
    if kind == KIND_MJ_PID:
        u[:] = 0.0
        for loop in range(int(cp[0])):
            o = 1 + loop * PID_WIDTH
            out, inp = int(cp[o]), int(cp[o + 1])
            u[inp] += _pid_block(cp, o + 2, cs, loop * _PID_STATE, r[out], meas[out])
    elif kind == KIND_MJ_LQR:
        _lqr(cp, r, meas, rd, u)


@njit(nogil=True, cache=CACHE)
def _closed_loop(steps, diffpos, ptrs, views, layout, sig, cp, opt, y_out, u_out, x_out):
    """The loop of the module docstring over ``sig.shape[0]`` periods.

    Parameters
    ----------
    steps : (mj_step1, mj_step2, mj_step) ctypes functions; ``diffpos``: mj_differentiatePos.
    ptrs : (2,) int64 addresses of the mjModel and the mjData.
    views : the mjData's qpos (nq), qvel (nv), act (na), sensordata, xquat (nbody, 4), ctrl (nu).
    layout : output table (p, 2) int64, input addresses (m,), the state's position dofs and velocity dofs,
        operating point qpos (nq), qvel (nv), act (na), input limits (m, 2), output limits |y| (p,).
    sig : (N, p + n_meas) the outputs' references, then the measurement noise.
    cp, opt : controller coefficients (module docstring), options (:data:`OPT_SIZE`).
    y_out (N, p), u_out (N, m), x_out (N, n) : outputs, saturated inputs, states per period.

    Returns
    -------
    (status, periods done): ``STATUS_OK``, ``STATUS_LIMIT`` (an output beyond its limit) or
    ``STATUS_DIVERGED`` (a non-finite or huge state).
    """
    step1, step2, step = steps
    mp, dp = ptrs[0], ptrs[1]
    qpos, qvel, act, sdata, xquat, ctrl = views
    src, inp_adr, pdofs, vdofs, qop, vop, aop, ulim, ylim = layout
    kind, n_sub, rk4, delay, div = int(opt[0]), int(opt[1]), opt[2] != 0.0, int(opt[3]), opt[4]
    n_steps, p, m, nx = sig.shape[0], src.shape[0], inp_adr.size, x_out.shape[1]
    y, x, u = np.empty(p), np.empty(nx), np.zeros(m)
    dq = np.empty(qvel.size)
    rd = np.empty(p)
    n_meas = nx if kind == KIND_MJ_LQR else p
    line = np.zeros((delay + 1, n_meas))
    cs = np.zeros(_PID_STATE * max(p, m, 1))
    for k in range(n_steps):
        step1(mp, dp)
        _read_outputs(src, qpos, qvel, sdata, xquat, y)
        _read_state(diffpos, mp, qpos, qvel, act, pdofs, vdofs, qop, vop, aop, dq, x)
        if _bad(qpos, div) or _bad(qvel, div) or _bad(y, div):
            return STATUS_DIVERGED, k
        y_out[k] = y
        x_out[k] = x
        for i in range(p):
            if abs(y[i]) > ylim[i]:
                return STATUS_LIMIT, k + 1
        slot = k % (delay + 1)
        for i in range(n_meas):
            line[slot, i] = (x[i] if kind == KIND_MJ_LQR else y[i]) + sig[k, p + i]
        _control(kind, cp, cs, sig[k, :p], line[max(k - delay, 0) % (delay + 1)], rd, u)
        for i in range(m):
            u[i] = min(max(u[i], ulim[i, 0]), ulim[i, 1])
            ctrl[inp_adr[i]] = u[i]
        u_out[k] = u
        if rk4:
            step(mp, dp)
        else:
            step2(mp, dp)
        for _ in range(n_sub - 1):
            step(mp, dp)
    return STATUS_OK, n_steps
