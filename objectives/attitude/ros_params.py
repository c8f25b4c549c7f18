"""A filter's ROS node parameters: how a deployed filter becomes the parameter file its ROS node loads.

A filter unit that a ROS node runs declares the node's parameters as a :class:`RosNode` (its class attribute
``ros``): the node's name, one :class:`RosParam` per deployed value the node takes (its ROS name, type, the node's
default and a unit change), and the node's documented parameter table with the defaults. ``tuner export RUN
--format ros2-params`` (or ``ros1-params``) writes the node's YAML from it (:func:`ros_yaml`); no filter is named
outside its unit.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

__all__ = ["RosParam", "RosNode", "ros_values", "ros_yaml", "FORMATS"]

#: export format -> ROS version
FORMATS = {"ros2-params": 2, "ros1-params": 1}


@dataclass(frozen=True)
class RosParam:
    """One node parameter: the deployed value ``value`` (the filter's name) written as ``name`` of type ``type``
    (float, bool or str); a number is divided by ``per``, the filter's units per node unit (1e6: the filter's uT
    to the node's tesla; said by ``unit``)."""

    value: str
    name: str
    type: type
    default: Any
    per: float = 1.0
    unit: str = ""


@dataclass(frozen=True)
class RosNode:
    """A ROS node's parameters (module docstring); ``documented``: its whole parameter table with defaults."""

    node: str
    params: tuple[RosParam, ...]
    documented: Mapping[str, Any] = field(default_factory=dict)
    #: deployed values the node has no parameter for, with the only value it can run (e.g. a fixed algorithm)
    implied: Mapping[str, Any] = field(default_factory=dict)


def ros_values(node: RosNode, values: Mapping[str, Any]) -> dict[str, Any]:
    """The node's parameter values from a deployment's ``values``.

    Raises ValueError naming every value the node cannot express: a value of the filter the node has no
    parameter for (other than the start option ``init: auto``, which the node's own start is), a number that is
    not finite, a value of the wrong type.
    """
    out: dict[str, Any] = {}
    bad: list[str] = []
    mapped = {p.value for p in node.params}
    for k, v in values.items():
        if k in mapped or (k == "init" and v in ("auto", "accmag")) or node.implied.get(k, object()) == v:
            continue
        if k == "init":
            why = "the node starts from its first sample: init auto"
        elif k in node.implied:
            why = f"the node runs {k} = {node.implied[k]!r} only"
        else:
            why = "the node has no such parameter"
        bad.append(f"{k} = {v!r} ({why})")
    for p in node.params:
        v = values.get(p.value, p.default)
        if p.type is bool:
            if not isinstance(v, bool):
                bad.append(f"{p.value} = {v!r} (a bool)")
                continue
            out[p.name] = v
        elif p.type is str:
            out[p.name] = str(v)
        else:
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(float(v)):
                bad.append(f"{p.value} = {v!r} (a finite number)")
                continue
            out[p.name] = float(v) / p.per
    if bad:
        raise ValueError(f"{node.node} cannot express: " + "; ".join(bad))
    return out


def ros_yaml(node: RosNode, values: Mapping[str, Any], version: int, comment: list[str]) -> str:
    """The node's parameter file: ROS 2 ``node: {ros__parameters: {...}}``, ROS 1 the plain mapping, with
    ``comment`` lines (provenance, scores) above. Numbers are written with repr, so they read back exactly."""
    vals = ros_values(node, values)

    def fmt(v: Any) -> str:
        if isinstance(v, bool):
            return "true" if v else "false"
        if isinstance(v, float):
            return repr(v)
        return '"' + str(v).replace("\\", "\\\\").replace('"', '\\"') + '"'

    lines = [f"# {c}" if c else "#" for c in comment]
    if version == 2:
        lines += [f"{node.node}:", "  ros__parameters:"] + [f"    {k}: {fmt(v)}" for k, v in vals.items()]
    else:
        lines += [f"{k}: {fmt(v)}" for k, v in vals.items()]
    return "\n".join(lines) + "\n"
