"""Slow plain-Python reference of the MuJoCo plant's compiled loop (objectives/control/plants/mujoco/kernel.py).

Written from the kernel's docstring, period by period, through MuJoCo's Python bindings (``mj_step1``,
``mj_step2``, ``mj_step``, ``mj_differentiatePos``) and without its code: outputs read from the ``mjData``,
the measurement with noise and a delay line, the controller as a Python closure, saturation, the controls
held over ``n_sub`` engine steps.
"""

import math

import mujoco
import numpy as np


def euler_zyx(q):
    """Roll, pitch, yaw of the unit quaternion ``q = (w, x, y, z)``."""
    w, x, y, z = q
    roll = math.atan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y))
    pitch = math.asin(max(-1.0, min(1.0, 2 * (w * y - z * x))))
    return roll, pitch, math.atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))


def mujoco_loop_reference(m, qpos0, qvel0, act0, ctrl0, read, state, controller, inputs, ulim, refs, noise, delay,
                          n_sub, state_feedback=False, rk4=False):
    """Closed loop over ``len(refs)`` periods.

    ``read(d) -> y`` and ``state(d) -> x`` read the outputs and the state; ``controller(r_row, meas) -> u``
    (``meas`` the state with ``state_feedback``, else the outputs); ``inputs`` the actuator indices, ``ulim``
    (m, 2); ``refs`` (N, p); ``noise`` (N, n_meas); ``delay`` periods. Returns y (N, p), u (N, m)."""
    d = mujoco.MjData(m)
    mujoco.mj_resetData(m, d)
    d.qpos[:], d.qvel[:], d.act[:], d.ctrl[:] = qpos0, qvel0, act0, ctrl0
    n = len(refs)
    ys, us, seen = [], [], []
    for k in range(n):
        mujoco.mj_step1(m, d)
        y = np.array(read(d), dtype=float)
        x = np.array(state(d), dtype=float)
        ys.append(y)
        seen.append((x if state_feedback else y) + noise[k])
        meas = seen[max(k - delay, 0)]
        u = np.array(controller(refs[k], meas), dtype=float)
        u = np.minimum(np.maximum(u, ulim[:, 0]), ulim[:, 1])
        for i, a in enumerate(inputs):
            d.ctrl[a] = u[i]
        us.append(u)
        if rk4:
            mujoco.mj_step(m, d)
        else:
            mujoco.mj_step2(m, d)
        for _ in range(n_sub - 1):
            mujoco.mj_step(m, d)
    return np.array(ys), np.array(us)


def state_reader(m, qpos_op, qvel_op, pdofs, vdofs):
    """``state(d)``: the tangent-space position difference at ``pdofs``, the velocities at ``vdofs``."""

    def state(d):
        dq = np.zeros(m.nv)
        mujoco.mj_differentiatePos(m, dq, 1.0, qpos_op, d.qpos)
        return np.r_[dq[pdofs], d.qvel[vdofs] - qvel_op[vdofs], d.act]

    return state
