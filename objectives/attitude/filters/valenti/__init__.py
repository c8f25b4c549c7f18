"""``valenti``, a unit: ``filter.py`` (the class, its declaration ``DECL`` and the node's parameter map
``ROS_NODE``), ``kernel.py`` (the numba kernel and its layouts), ``port.c`` (the C port)."""

from objectives.attitude.filters.valenti.filter import DECL, ROS_NODE, Valenti

__all__ = ["Valenti", "DECL", "ROS_NODE"]
