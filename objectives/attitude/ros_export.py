"""The filter objective's export formats of its own (hooks ``export_formats`` and ``export_as``): the parameter
file of the ROS node that runs the deployed filter, for a filter whose class declares one (``ros``, a
:class:`objectives.attitude.ros_params.RosNode`). ``tuner export RUN --format ros2-params`` (or ``ros1-params``)."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from objectives.attitude.ros_params import FORMATS, ros_yaml

__all__ = ["export_formats", "export_as"]


def export_formats(obj: Any) -> dict[str, str]:
    """``{format: help}`` of the objective's filter: the ROS parameter files when its class declares a node."""
    node = getattr(obj._cls, "ros", None)
    if node is None:
        return {}
    return {"ros2-params": f"the parameter YAML of the ROS 2 node {node.node} (node: ros__parameters: ...)",
            "ros1-params": f"the parameter YAML of the ROS 1 node {node.node} (the plain mapping, rosparam load)"}


def export_as(obj: Any, fmt: str, params: Mapping[str, Any], comment: str = "") -> str:
    """The text of format ``fmt`` for the deployed filter of ``params``; ``comment`` (provenance, scores) leads it
    as YAML comments. ValueError naming every value the node cannot express."""
    from objectives.attitude.deployment import filter_build

    node = getattr(obj._cls, "ros", None)
    if node is None or fmt not in FORMATS:
        raise ValueError(f"format {fmt!r}: not a format of filter {obj.filter!r}")
    flt = filter_build(obj, params)
    rate, _ = obj.sample_rate()
    lines = [f"{node.node} parameters: the filter {flt.name} deployed by tuner", *comment.splitlines()]
    if rate is not None:
        lines.append(f"tuned at {rate:g} Hz; the node integrates over its stamps' differences")
    return ros_yaml(node, flt.values, FORMATS[fmt], lines)
