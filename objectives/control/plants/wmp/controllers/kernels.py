"""Numba controller step functions, dispatched by an integer kind inside the closed-loop kernel.

The closed-loop simulator (:func:`objectives.control.plants.wmp.model._simulate`) calls
:func:`controller_step` once per controller period ``Ts``. A controller is described by three
numbers the kernel understands:

- ``kind`` (int): which branch below runs (the ``KIND_WMP_*`` constants of :mod:`objectives.control.kinds`);
- ``p`` (float64 array): its parameters, laid out by the Python class that builds it
  (``Controller.param_array``);
- ``s`` (float64 array): its internal state (integrators, previous errors), zeroed at the start of
  a simulation, sized by ``Controller.state_size``.

Adding a controller (for example the fuzzy controllers in ``controllers/fuzzy.py``) means:

1. write an ``@njit`` step function ``_my_step(p, s, ref, meas, x, u_out)`` (in its own module, e.g.
   ``fuzzy_steps.py``; not cached on its own: the closed-loop driver's cache entry holds it, rules 2 and 3
   of :mod:`objectives.jit`);
2. give it a new ``KIND_WMP_*`` constant in :mod:`objectives.control.kinds` (the one kind space) and one
   ``elif kind == KIND_WMP_...`` branch in :func:`controller_step` that calls it;
3. write the Python class (subclass of :class:`objectives.control.plants.wmp.controllers.base.Controller`)
   with ``kind`` set to the constant, and register its ``"module:Class"`` in the one controller registry,
   :data:`objectives.control.controllers.CONTROLLERS`.

Signals passed to every step function (all float64, SI units unless stated):

``ref`` (2,)
    desired linear speed nu_d (m/s) and yaw rate xi_d (rad/s) at this sample.
``meas`` (5,)
    what the robot's sensors give (thesis Table 1.1 and section 2.2.3.1): linear speed from the
    encoders (m/s), the Kalman estimate of theta3 (rad, eq. 2.20), gyroscope rate omega3 (rad/s),
    yaw rate from the encoders (rad/s), average motor current I_A (A).
``x`` (8,)
    the true plant state (theta1, theta2, theta3, their rates, I1, I2), for full-state-feedback
    controllers that assume perfect measurement (the LQR design case).
``u_out`` (2,)
    written by the step: motor voltages (u1, u2) before saturation (V).
"""

from __future__ import annotations

import math

from numba import njit

from objectives.control.kinds import (
    KIND_WMP_FLC,
    KIND_WMP_LQG,
    KIND_WMP_LQR,
    KIND_WMP_LUT_FUZZY,
    KIND_WMP_OPEN,
    KIND_WMP_PID,
    KIND_WMP_PROTECTIVE_FUZZY,
)
from objectives.control.plants.wmp.controllers.fuzzy_steps import _flc_step, _lut_step, _protective_step

__all__ = ["controller_step", "LQ_PARAM_SIZE", "PID_PARAM_SIZE", "PID_STATE_SIZE"]

#: layout of the LQ parameter array: K (2x4 row-major), then Fr (2x2 row-major): u = -K z + Fr r
LQ_PARAM_SIZE = 12
#: layout of the PID parameter array (see :func:`_pid_step`)
PID_PARAM_SIZE = 10
PID_STATE_SIZE = 7


@njit
def _lq_step(p, z0, z1, z2, z3, ref, u_out):
    """u = -K z + Fr r with z = (theta3, nu, omega3, xi) and r = (nu_d, xi_d) (eqs. 2.15, 2.19)."""
    for i in range(2):
        u_out[i] = (
            -(p[4 * i] * z0 + p[4 * i + 1] * z1 + p[4 * i + 2] * z2 + p[4 * i + 3] * z3)
            + p[8 + 2 * i] * ref[0]
            + p[8 + 2 * i + 1] * ref[1]
        )


@njit
def _tustin_pid(kp, ki, kd, ts, e, st, o):
    """One Tustin PID step (eq. 2.38); state st[o:o+3] = (e_prev, integral, derivative).

    Integral: I_k = I_{k-1} + Ki Ts/2 (e_k + e_{k-1}); derivative: D_k = -D_{k-1} + 2 Kd/Ts (e_k - e_{k-1}),
    the difference equations of Ki Ts/2 (z+1)/(z-1) and 2 Kd/Ts (z-1)/(z+1).
    """
    e_prev = st[o]
    integ = st[o + 1] + ki * ts * 0.5 * (e + e_prev)
    der = -st[o + 2] + 2.0 * kd / ts * (e - e_prev)
    st[o] = e
    st[o + 1] = integ
    st[o + 2] = der
    return kp * e + integ + der


@njit
def _pid_step(p, s, ref, meas, u_out):
    """PID equivalents of thesis 2.3.2 combined by eq. 2.31.

    p = (kp1, ki1, kd1, kp2, ki2, kd2, yaw_gain_V, yaw_range_rad_s, Ts, first_flag_unused).
    PID1: e_nu = nu_d - nu (m/s) -> u_nu (V). PID2: e_theta3 = -theta3_hat in degrees -> u_theta3 (V)
    (degrees: the unit in which the thesis's gains K_P2 = 0.03, K_D2 = 3e-5 are of sensible size).
    Yaw: u_xi,k = u_xi,k-1 + yaw_gain * clip(e_xi / yaw_range, -1, 1) (the linear equivalent of FLC3
    with uniform N/Z/P triangles, eq. 2.30). u1 = u_nu + u_theta3 - u_xi, u2 = u_nu + u_theta3 + u_xi.
    s = (e1_prev, I1, D1, e2_prev, I2, D2, u_xi).
    """
    ts = p[8]
    e_nu = ref[0] - meas[0]
    e_th = meas[1] * (180.0 / math.pi)
    u_nu = _tustin_pid(p[0], p[1], p[2], ts, e_nu, s, 0)
    u_th = _tustin_pid(p[3], p[4], p[5], ts, e_th, s, 3)
    e_xi = (ref[1] - meas[3]) / p[7]
    if e_xi > 1.0:
        e_xi = 1.0
    elif e_xi < -1.0:
        e_xi = -1.0
    s[6] += p[6] * e_xi
    u_out[0] = u_nu + u_th - s[6]
    u_out[1] = u_nu + u_th + s[6]


@njit(cache=False)  # compiled into the closed-loop driver (rule 2 of objectives.jit)
def controller_step(kind, p, s, ref, meas, x, r_wheel, d_wheels, u_out):
    """Dispatch one controller step by ``kind`` (see the module docstring for the signals).

    ``r_wheel`` and ``d_wheels`` (m) convert the true state to (nu, xi) for full-state feedback.
    Unknown kinds write NaN voltages, which the simulator reports as a diverged run.
    """
    if kind == KIND_WMP_PID:
        _pid_step(p, s, ref, meas, u_out)
    elif kind == KIND_WMP_LQR:
        nu = 0.5 * r_wheel * (x[3] + x[4])
        xi = r_wheel * (x[4] - x[3]) / d_wheels
        _lq_step(p, x[2], nu, x[5], xi, ref, u_out)
    elif kind == KIND_WMP_LQG:
        _lq_step(p, meas[1], meas[0], meas[2], meas[3], ref, u_out)
    elif kind == KIND_WMP_PROTECTIVE_FUZZY:
        _protective_step(p, s, ref, meas, u_out)
    elif kind == KIND_WMP_LUT_FUZZY:
        _lut_step(p, s, ref, meas, u_out)
    elif kind == KIND_WMP_FLC:
        _flc_step(p, s, ref, meas, u_out)
    elif kind == KIND_WMP_OPEN:
        u_out[0] = p[0]
        u_out[1] = p[1]
    else:
        u_out[0] = math.nan
        u_out[1] = math.nan
