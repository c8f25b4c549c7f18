"""The one space of controller kinds: the integer a closed-loop kernel dispatches a controller step on.

Every controller class (:mod:`objectives.control.controllers`) names its kind here, and each loop kernel
branches on these constants only, so two controllers never share a number. Two kernels read them:

- the loop of the plants that run the generic single-loop kernels (:mod:`objectives.control.plants.kernels`:
  LTI models, Python dynamics, FMUs): ``KIND_OPEN`` .. ``KIND_SF``;
- the wheeled mobile pendulum's own loop with its sensors and Kalman filter
  (:mod:`objectives.control.plants.wmp.controllers.kernels`): ``KIND_WMP_*``;
- the loop of MuJoCo plants, several inputs and outputs at once (:mod:`objectives.control.plants.mujoco.kernel`):
  ``KIND_MJ_*``.

A new controller of an existing loop takes the next free number of its block here and adds one branch to
that loop's dispatch; a plant unit with its own loop kernel takes a new block of ten.
"""

from __future__ import annotations

__all__ = ["KIND_OPEN", "KIND_PID", "KIND_CASCADE", "KIND_SF", "KIND_WMP_OPEN", "KIND_WMP_LQR", "KIND_WMP_LQG",
           "KIND_WMP_PID", "KIND_WMP_FLC", "KIND_WMP_PROTECTIVE_FUZZY", "KIND_WMP_LUT_FUZZY", "KIND_MJ_PID",
           "KIND_MJ_LQR", "KINDS"]

# the generic single loop (objectives.control.plants.kernels._control)
KIND_OPEN = 0  #: no feedback: the reference drives input 0 (plant step responses)
KIND_PID = 1  #: one two-degree-of-freedom PID block on the controlled output
KIND_CASCADE = 2  #: an outer PID block setting the inner block's reference
KIND_SF = 3  #: state feedback u = -K x + Nbar r

# the wheeled mobile pendulum (objectives.control.plants.wmp.controllers.kernels.controller_step)
KIND_WMP_OPEN = 10  #: constant voltages p = (u1, u2)
KIND_WMP_LQR = 11  #: full-state feedback on the true controllable state (thesis 2.2.1)
KIND_WMP_LQG = 12  #: the same gains on measured signals with the KF estimate of theta3
KIND_WMP_PID = 13  #: PID1 (speed) + PID2 (theta3) + incremental yaw loop, Tustin (eq. 2.38)
KIND_WMP_FLC = 20  #: cascade FLC1-3 (thesis 2.2.2)
KIND_WMP_PROTECTIVE_FUZZY = 21  #: protective PI fuzzy FLC1 + FLC2 + FLC3 (thesis 2.3.1)
KIND_WMP_LUT_FUZZY = 22  #: the protective scheme through look-up tables (eq. 2.32)

# MuJoCo plants (objectives.control.plants.mujoco.kernel._control)
KIND_MJ_PID = 30  #: one two-degree-of-freedom PID block per loop (output -> actuator), several loops at once
KIND_MJ_LQR = 31  #: state feedback from the model's linearisation, u = u_op + Nu r - K (x - Nx r)

#: every kind by its number (a test checks that no two constants share one)
KINDS = {v: k for k, v in sorted(globals().items()) if k.startswith("KIND_") and isinstance(v, int)}
