"""The linearisation of a MuJoCo plant at its operating point over one controller period.

MuJoCo's finite-difference transition derivatives (``mjd_transitionFD``, centred differences) give the
map of one engine step at the operating point ``(qpos, qvel, act, ctrl)``:
``dx[t+1] = A dx[t] + B du[t]`` in the state ``(dq, dqvel, dact)`` (``2 nv + na``; ``dq`` in the tangent
space of ``mj_differentiatePos``). The controller holds its input over ``n_sub`` steps, so one period is

    Ad = A^n_sub,    Bd = (A^(n_sub-1) + ... + A + I) B,

exact for the linearisation at an equilibrium (each step's Jacobians are the same). The plant's state keeps
the rows and columns of the positions and velocities of the dofs of ``state_joints`` and every activation:
dropping a coordinate is right when nothing depends on it (a cart's position, a heading, a wheel's angle:
cyclic coordinates), which the caller states by leaving the joint, or its position, out.

MuJoCo has no transition derivatives for RK4: a model integrated with RK4 is linearised with the
``implicitfast`` integrator on a copy of the model (the same continuous dynamics, another one-step map:
the difference in ``Ad`` is of the order of the timestep).
"""

from __future__ import annotations

import copy
from typing import Any

import numpy as np

__all__ = ["step_model", "period_model", "EPS"]

#: finite-difference step of mjd_transitionFD (its documentation's usual value)
EPS = 1e-6


def step_model(plant: Any) -> tuple[np.ndarray, np.ndarray]:
    """``(A, B)`` of one engine step at the plant's operating point, full state ``(2 nv + na)`` and every
    actuator (``nu`` columns)."""
    import mujoco

    m = plant.mj
    if plant.rk4:
        m = copy.copy(m)
        m.opt.integrator = int(mujoco.mjtIntegrator.mjINT_IMPLICITFAST)
    d = mujoco.MjData(m)
    mujoco.mj_resetData(m, d)
    d.qpos[:], d.qvel[:], d.act[:], d.ctrl[:] = plant.qpos_op, plant.qvel_op, plant.act_op, plant.ctrl_op
    mujoco.mj_forward(m, d)
    n = 2 * m.nv + m.na
    a, b = np.zeros((n, n)), np.zeros((n, m.nu))
    mujoco.mjd_transitionFD(m, d, EPS, True, a, b, None, None)
    return a, b


def period_model(plant: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(Ad, Bd, residual)``: the period map of the module docstring in the plant's state and inputs, and
    how far the operating point moves in one period with its inputs held (0 at an equilibrium; the state's
    change, in the plant's state coordinates)."""
    import mujoco

    a, b = step_model(plant)
    m = plant.mj
    ad, acc = np.eye(a.shape[0]), np.zeros_like(a)
    for _ in range(plant.n_sub):
        acc = acc + ad
        ad = a @ ad
    bd = acc @ b
    nv, na = m.nv, m.na
    keep = np.r_[plant.pdofs, nv + plant.vdofs, 2 * nv + np.arange(na)].astype(int)
    ad_k = np.ascontiguousarray(ad[np.ix_(keep, keep)])
    bd_k = np.ascontiguousarray(bd[np.ix_(keep, plant.inp_adr)])
    d = plant.new_data()
    mujoco.mj_step(m, d, plant.n_sub)
    dq = np.zeros(nv)
    mujoco.mj_differentiatePos(m, dq, 1.0, plant.qpos_op, d.qpos)
    full = np.r_[dq, d.qvel - plant.qvel_op, d.act - plant.act_op]
    return ad_k, bd_k, full[keep]
