"""``imu_tools_madgwick``: the filter of the ROS node ``imu_filter_madgwick`` (package imu_tools), as the node runs it.

Algorithm: S. O. H. Madgwick, "An efficient orientation filter for inertial and inertial/magnetic sensor arrays",
report, University of Bristol, 2010 (the "report"): the gradient-descent correction (eqs. 20-21, 25-34) with the
gain ``gain`` (beta, eq. 33) and the gyro drift compensation with ``zeta`` (eqs. 47-49). The node's behaviour,
from its documentation (ROS wiki and README parameter tables) and the report, written here without its source:

- **world frames** (``world_frame``: enu, ned, nwu; REP-103's ENU is the node's default): the gravity reference is
  up (+z, or -z in NED) and the magnetic reference lies on the frame's north axis (y in ENU, x in NED and NWU),
  with the report's eq. 46 field ``b = (|h_xy|, 0, h_z)`` from ``h = q m q*`` (eq. 45) at full length;
- **start** (``init: auto``): the first sample sets the orientation without filtering ("stateless"): east
  ``H = m x a``, north ``M = a x H``, the world axes as the rows of the rotation; the start fails (the sample is
  skipped, its output NaN) when ``|m x a| < 1e-7``. Without a magnetometer the node has no heading reference and
  takes a horizontal one of its own; here ``(a_y, a_x, 0)`` when ``|a_x|`` or ``|a_y|`` exceeds 0.1, else
  ``(0, a_z, a_y)`` (the heading of an IMU-only start is arbitrary either way). The start sample is then updated
  with ``dt = 0`` (its stamp is the last stamp), which leaves the orientation as started;
- **dt from stamps**: each later sample is integrated over the time since the one before, here the recording's
  sample time (a recording has one rate; a bag's stamps are read into it by ``resample_hz`` or the jitter check);
- **MARG and IMU updates**: with ``use_mag`` and a finite, non-zero field the MARG update (gravity and field
  gradients, then the drift: ``omega_eps = 2 q* s`` with the normalised gradient ``s``, ``omega_b += zeta
  omega_eps dt``, the rate compensated with the new ``omega_b``, eqs. 47-49, then eqs. 12, 42-43); otherwise the
  IMU update (gravity only, no drift term, the raw rate). An all-zero accelerometer sample is integrated from the
  gyroscope alone;
- **magnetometer bias** ``mag_bias_x/y/z`` is subtracted from the field before anything uses it (in the
  recording's field unit; a bag's field is read in uT, and the export writes tesla).

Choices where the node may differ: the node computes in single precision for part of its arguments and may use a
fast approximate inverse square root; this unit computes in double with exact square roots (differences of order
1e-6 rad per sample, far below the attitude errors that tuning changes).
Output: sensor-to-earth ``(w, x, y, z)`` in ``world_frame``, converted to the recording's frame.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from objectives.attitude.cexport.port import CMember, CPort
from objectives.attitude.filters.base import G_SI, KernelSetup
from objectives.attitude.filters.imu_tools_madgwick.kernel import (
    FRAMES,
    S,
    coefficients,
    imu_tools_madgwick_kernel,
    initial_state,
)
from objectives.attitude.filters.node_stream import NodeFilter
from objectives.attitude.ros_params import RosNode, RosParam
from objectives.params import NONNEG, Param, ParamSet

__all__ = ["ImuToolsMadgwick", "DECL", "ROS_NODE"]

_REP = "Madgwick 2010 report"

#: the one declaration (defaults: the node's)
DECL = ParamSet("imu_tools_madgwick", (
    Param("gain", 0.1, (1e-3, 1.0), "log", "rad/s", "gradient step gain beta (the node's gain)", f"{_REP} eq. 33",
          NONNEG),
    Param("zeta", 0.0, None, unit="1/s", doc="gyro drift gain (MARG update only), 0 = off", eq=f"{_REP} eq. 48",
          allowed=NONNEG),
    Param("world_frame", "enu", choices=tuple(FRAMES), doc="the node's world frame: enu (REP-103), ned or nwu"),
    Param("use_mag", True, doc="MARG (true) or IMU (false) update"),
    Param("mag_bias_x", 0.0, unit="field unit", doc="magnetometer bias, subtracted (a bag's field: uT)"),
    Param("mag_bias_y", 0.0, unit="field unit", doc="magnetometer bias, subtracted"),
    Param("mag_bias_z", 0.0, unit="field unit", doc="magnetometer bias, subtracted"),
))

#: the node's parameters (imu_filter_madgwick's documented table, ROS 1 and ROS 2) and how each deployed value
#: maps onto one; the node's other parameters keep their defaults
ROS_NODE = RosNode("imu_filter_madgwick", (
    RosParam("gain", "gain", float, 0.1),
    RosParam("zeta", "zeta", float, 0.0),
    RosParam("mag_bias_x", "mag_bias_x", float, 0.0, per=1e6, unit="T (from uT)"),
    RosParam("mag_bias_y", "mag_bias_y", float, 0.0, per=1e6, unit="T (from uT)"),
    RosParam("mag_bias_z", "mag_bias_z", float, 0.0, per=1e6, unit="T (from uT)"),
    RosParam("world_frame", "world_frame", str, "enu"),
    RosParam("use_mag", "use_mag", bool, True),
), documented={"gain": 0.1, "zeta": 0.0, "mag_bias_x": 0.0, "mag_bias_y": 0.0, "mag_bias_z": 0.0,
               "orientation_stddev": 0.0, "world_frame": "enu", "use_mag": True, "fixed_frame": "odom",
               "publish_tf": True, "reverse_tf": False, "constant_dt": 0.0, "publish_debug_topics": False,
               "stateless": False, "remove_gravity_vector": False})


#: the C port (port.c, ported from kernel.py line by line): the state array of the kernel's layout S
C_PORT = CPort((__package__, "port.c"), ("node.c",), (CMember("real", "s", (S.LEN,)), CMember("params", "p")),
               layouts=(S,))


class ImuToolsMadgwick(NodeFilter):
    """The filter of ``imu_filter_madgwick`` (module docstring). Searched by default: ``gain``.
    ``run_detailed`` adds the diagnostic ``gyr_bias`` (N, 3), rad/s (omega_b of the MARG update)."""

    c_port = C_PORT

    name = "imu_tools_madgwick"
    decl = DECL
    needs_mag = True
    working_frame = "ENU"
    ros = ROS_NODE
    kernel = staticmethod(imu_tools_madgwick_kernel)

    def __init__(self, **values: Any):
        super().__init__(**values)
        self.working_frame = str(self.values["world_frame"]).upper()

    def kernel_setup(self, dt: float, use_mag: bool, q0: np.ndarray | None, frame: str,
                     g_ref: float = G_SI) -> KernelSetup:
        """Coefficients at sample time ``dt`` s and the start state: ``q0`` (sensor-to-earth in the world frame)
        or, for None, the node's own start from the first sample. ``frame`` and ``g_ref`` do not enter."""
        if not (np.isfinite(dt) and dt > 0):
            raise ValueError(f"imu_tools_madgwick: dt must be a positive number of seconds, got {dt!r}")
        return KernelSetup(coefficients(self.values, dt, use_mag), initial_state(q0))
