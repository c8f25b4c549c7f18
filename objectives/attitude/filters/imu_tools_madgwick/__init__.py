"""``imu_tools_madgwick``, a unit: ``filter.py`` (the class, its declaration ``DECL`` and the node's parameter map
``ROS_NODE``), ``kernel.py`` (the numba kernel and its layouts), ``port.c`` (the C port)."""

from objectives.attitude.filters.imu_tools_madgwick.filter import DECL, ROS_NODE, ImuToolsMadgwick

__all__ = ["ImuToolsMadgwick", "DECL", "ROS_NODE"]
