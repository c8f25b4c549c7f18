"""PID equivalents of the cascade fuzzy controllers (thesis section 2.3.2, eqs. 2.37-2.38, 2.31).

PID1 acts on the speed error e_nu = nu_d - nu (m/s) and gives u_nu (V); PID2 acts on the oscillation
error e_theta3 = -theta3_hat, in degrees, and gives u_theta3 (V); both are discretised with Tustin's
rule (eq. 2.38) at Ts. The sign of e_theta3: with theta3 > 0 meaning the centre of mass ahead of
the axle (eq. 2.3), accelerating forward swings it back (theta3 < 0) and the thesis's FLC2/PID2 must
then *reduce* the voltage (section 2.2.2.2), so the oscillation error fed to PID2 is +theta3_hat here
(the thesis's figures evidently measure theta3 the other way round).

The yaw loop (FLC3 in the thesis) is "not replaced nor optimised"; we use the exact linear
equivalent of FLC3's structure (N/Z/P triangles uniformly covering +-30 deg/s with singletons
-g, 0, g and weighted-average defuzzification is linear interpolation), so eq. 2.30 becomes
u_xi,k = u_xi,k-1 + g * clip(e_xi / 30 deg/s, -1, 1). The thesis keeps FLC3 in this scheme ("not
replaced nor optimized", 2.3.2), so g is FLC3's Table 2.7 gain u3 = 1.5 under the time-integrator
reading of eq. 2.30 used by the fuzzy controllers (u3 in V/s, see :mod:`.fuzzy`): g = u3 Ts = 0.015 V
per 10 ms period, the same yaw loop as the fuzzy scheme's initial FLC3 (yaw rate 90 % in 0.27 s).
(Read per sample, 1.5 V is unstable on our model: linearised yaw dynamics dxi/dt = -58 xi + 153 u_xi
put the discrete closed-loop pole at z = -1.31. The earlier default 0.15 V was 10x FLC3.)
The voltages are combined by eq. 2.31: u1 = u_nu + u_theta3 - u_xi, u2 = u_nu + u_theta3 + u_xi
(u2 > u1 turns left, xi = r (dtheta2 - dtheta1) / d > 0).

Note that eq. 2.38's derivative term 2 K_D / Ts (z - 1) / (z + 1) has a pole at z = -1: once excited
(by sensor noise), it keeps the voltage alternating at the Nyquist rate with amplitude ~ 2 K_D / Ts
times the error step; with the initial K_D2 = 3e-5 V s/deg this is ~1.4 V, which is why the tuned
K_D2 (5.12e-7) is small.

With these choices the thesis's optimised gains (K_P1 = 8.80, K_I1 = 19.07, K_P2 = 0.054,
K_D2 = 5.12e-7) give a peak IB angle of 51 deg and a peak current of 0.56 A on the thesis profile,
against 56.8 deg and 0.54 A reported in section 2.3.4.

Default bounds and initial values: Table 2.7 (K_P1 in [1, 24], K_I1 in [5, 35], K_P2 in
[0.002, 0.1], K_D2 in [7e-8, 5e-5]; K_D1 = K_I2 = 0 fixed, as in the thesis).
"""

from __future__ import annotations

import math

import numpy as np

from objectives.control.kinds import KIND_WMP_PID
from objectives.control.plants.wmp.controllers.base import Controller
from objectives.control.plants.wmp.controllers.kernels import PID_STATE_SIZE
from objectives.params import POSITIVE, Param, ParamSet

__all__ = ["PID"]


class PID(Controller):
    """PID1 (speed) + PID2 (IB angle) + fixed incremental yaw loop."""

    name = "pid"
    kind = KIND_WMP_PID
    state_size = PID_STATE_SIZE
    decl = ParamSet("controller 'pid'", (
        Param("kp1", 12.0, (1.0, 24.0), unit="V s/m", doc="PID1 proportional gain", eq="eq. 2.38, Table 2.7"),
        Param("ki1", 25.0, (5.0, 35.0), unit="V/m", doc="PID1 integral gain", eq="eq. 2.38, Table 2.7"),
        Param("kd1", 0.0, unit="V s^2/m", doc="PID1 derivative gain", eq="eq. 2.38"),
        Param("kp2", 0.03, (0.002, 0.1), unit="V/deg", doc="PID2 proportional gain", eq="eq. 2.38, Table 2.7"),
        Param("ki2", 0.0, unit="V/(deg s)", doc="PID2 integral gain", eq="eq. 2.38"),
        Param("kd2", 3e-5, (7e-8, 5e-5), "log", unit="V s/deg", doc="PID2 derivative gain",
              eq="eq. 2.38, Table 2.7"),
        Param("yaw_gain_V", 0.015, unit="V", doc="yaw loop voltage step per period at full error",
              eq="eq. 2.30; FLC3 of Table 2.7 (u3 = 1.5 V/s times Ts), section 2.3.2"),
        Param("yaw_range_deg_s", 30.0, unit="deg/s", doc="yaw error at which the step saturates", eq="eq. 2.30",
              allowed=POSITIVE),
    ))

    def _build(self, v):
        return np.array(
            [
                v["kp1"],
                v["ki1"],
                v["kd1"],
                v["kp2"],
                v["ki2"],
                v["kd2"],
                v["yaw_gain_V"],
                math.radians(v["yaw_range_deg_s"]),
                self.sensors.Ts_s,
                0.0,
            ]
        )
