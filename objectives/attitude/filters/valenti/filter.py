"""``valenti``: the complementary filter of R. G. Valenti, I. Dryanovski and J. Xiao, "Keeping a Good Attitude:
A Quaternion-Based Orientation Filter for IMUs and MARGs", Sensors 2015, 15(8), 19302-19330, as the ROS node
``imu_complementary_filter`` (package imu_tools) runs it.

The paper (section 5): the gyroscope predicts (eqs. 38-42); the accelerometer corrects only the tilt through a
delta quaternion from the predicted gravity (eqs. 44-47), taken in the fraction ``gain_acc`` of the way from the
identity by LERP or, when the delta is large (its scalar part below 0.9), SLERP (eqs. 48-53); the magnetometer
corrects only the heading through a delta quaternion about the vertical (eqs. 54-59) with ``gain_mag``. The
adaptive gain (section 5.4, eqs. 60-61) scales ``gain_acc`` by a factor of the relative error of the
acceleration's magnitude: 1 below 0.1, falling linearly to 0 at 0.2. Implemented from the paper and the node's
documentation (ROS wiki parameter table), not its source; the choices where the node goes beyond the paper or
may differ from it:

- **bias estimation** (``do_bias_estimation``, ``bias_alpha``; not in the paper): at steady state the gyro bias
  follows the raw rate through a first-order low-pass, ``b += bias_alpha (omega - b)``, before the prediction,
  which then uses ``omega - b``. Steady state: ``| |a| - 9.81 | <= 0.1`` m/s^2, every rate within 0.01 rad/s of the
  last sample's and within 0.2 rad/s of the bias estimate. The bias starts at zero, the last rate at zero (the
  start sample does not set it);
- **gravity** is the node's 9.81 m/s^2 (adaptive gain and steady state), scaled for an accelerometer in g;
- **start**: the first sample sets the orientation from the accelerometer (eq. 25) and, with ``use_mag``, the
  field (eqs. 26-36), and is not filtered; both forms of eqs. 25 and 35 are used (a singular first form cannot
  give NaN). Later samples are integrated over the recording's sample time (the node: its stamps' difference);
- the prediction is normalised before the correction; the final quaternion is normalised;
- the global frame is NWU (x on the field's horizontal direction with a magnetometer, eq. 35); without one the
  heading starts at zero and is free. The output, the inverse of the paper's ``^L_G q``, is converted to the
  recording's frame.

Defaults are the node's (``use_mag: false``).
"""

from __future__ import annotations

import numpy as np

from objectives.attitude.cexport.port import CField, CMember, CPort
from objectives.attitude.filters.base import G_SI, KernelSetup
from objectives.attitude.filters.node_stream import NodeFilter
from objectives.attitude.filters.valenti.kernel import S, coefficients, initial_state, valenti_kernel
from objectives.attitude.ros_params import RosNode, RosParam
from objectives.params import Interval, Param, ParamSet

__all__ = ["Valenti", "DECL", "ROS_NODE"]

_REF = "Valenti et al. 2015"
_UNIT = Interval(0.0, 1.0)

#: the one declaration (defaults: the node's)
DECL = ParamSet("valenti", (
    Param("gain_acc", 0.01, (1e-4, 0.5), "log", "1", "accelerometer correction gain alpha (fraction of the "
          "delta quaternion per sample)", f"{_REF} eqs. 48-53", _UNIT),
    Param("gain_mag", 0.01, (1e-4, 0.5), "log", "1", "magnetometer correction gain beta", f"{_REF} eqs. 54-59",
          _UNIT),
    Param("bias_alpha", 0.01, (1e-4, 0.5), "log", "1", "gyro bias low-pass gain at steady state", "the node",
          _UNIT),
    Param("do_bias_estimation", True, doc="estimate the gyro bias at steady state"),
    Param("do_adaptive_gain", True, doc="scale gain_acc by the acceleration magnitude error", eq=f"{_REF} eq. 61"),
    Param("use_mag", False, doc="correct the heading with the magnetometer (the node's default: false)"),
))

#: the node's parameters (imu_complementary_filter's documented table) and how each deployed value maps onto one
ROS_NODE = RosNode("imu_complementary_filter", (
    RosParam("gain_acc", "gain_acc", float, 0.01),
    RosParam("gain_mag", "gain_mag", float, 0.01),
    RosParam("bias_alpha", "bias_alpha", float, 0.01),
    RosParam("do_bias_estimation", "do_bias_estimation", bool, True),
    RosParam("do_adaptive_gain", "do_adaptive_gain", bool, True),
    RosParam("use_mag", "use_mag", bool, False),
), documented={"gain_acc": 0.01, "gain_mag": 0.01, "bias_alpha": 0.01, "do_bias_estimation": True,
               "do_adaptive_gain": True, "use_mag": False, "fixed_frame": "odom", "publish_tf": False,
               "reverse_tf": False, "constant_dt": 0.0, "publish_debug_topics": False, "orientation_stddev": 0.0})


def _c_fields(v: dict, ctx) -> list[CField]:
    """The node's gravity 9.81 m/s^2 in the recording's accelerometer unit (``ctx.g`` is 9.80665 in it)."""
    return [CField("real", "g_node", 9.81 * ctx.g / 9.80665, "the node's gravity, in the accelerometer's unit")]


#: the C port (port.c, ported from kernel.py line by line): the state array of the kernel's layout S
C_PORT = CPort((__package__, "port.c"), ("node.c",), (CMember("real", "s", (S.LEN,)), CMember("params", "p")),
               layouts=(S,), fields=_c_fields, gravity=True)


class Valenti(NodeFilter):
    """The complementary filter of Valenti et al. 2015 as ``imu_complementary_filter`` runs it (module
    docstring). Searched by default: ``gain_acc``, ``gain_mag``, ``bias_alpha``. ``run_detailed`` adds the
    diagnostic ``gyr_bias`` (N, 3), rad/s."""

    c_port = C_PORT

    name = "valenti"
    decl = DECL
    needs_mag = True
    working_frame = "NWU"
    ros = ROS_NODE
    kernel = staticmethod(valenti_kernel)

    def kernel_setup(self, dt: float, use_mag: bool, q0: np.ndarray | None, frame: str,
                     g_ref: float = G_SI) -> KernelSetup:
        """Coefficients at sample time ``dt`` s (``g_ref``: standard gravity in the accelerometer's unit) and the
        start state: ``q0`` (sensor-to-earth, NWU) or, for None, the node's start from the first sample."""
        if not (np.isfinite(dt) and dt > 0):
            raise ValueError(f"valenti: dt must be a positive number of seconds, got {dt!r}")
        return KernelSetup(coefficients(self.values, dt, use_mag, g_ref), initial_state(q0))
