"""The filter objective's ``deployment`` and ``build`` hooks: the complete tuned filter.

The deployed filter is defined by every value of its declaration: the searched ones, the fixed ones
(``objective.fixed``, ``parameters: {x: {fixed: v}}``, bare values) and the defaults of the rest.
The start orientation is the one setting that may only serve scoring: ``init: truth`` (or
``objective.q0: truth`` / a quaternion under ``init: auto``) needs ground truth that live data do not
have, so the deployed filter starts from the first accelerometer/magnetometer sample (``init:
accmag``) and ``scoring.init`` records the start the run was scored with. Any other start is
resolved (``auto`` becomes the run's ``q0``: ``accmag`` or ``broad``) so that the deployed filter
starts exactly as it did in the run, without depending on the objective.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from tuner.deployment import Deployment, build_deployment

__all__ = ["filter_deployment", "filter_build", "deployed_values", "LIVE_START_NOTE"]

#: what the exports say about the start of the deployed filter when the run was scored from truth
LIVE_START_NOTE = ("the run was scored with the start orientation taken from ground truth ({start}); "
                   "live data have none, so the deployed filter starts from the first accelerometer and "
                   "magnetometer sample (init: accmag)")


def _start(obj: Any, values: Mapping[str, Any]) -> Any:
    """The start the run's scoring used: the filter's ``init`` unless ``auto``, else ``objective.q0``."""
    init = values.get("init", "auto")
    return obj.q0 if init == "auto" else init


def deployed_values(obj: Any, params: Mapping[str, Any]) -> tuple[dict[str, Any], dict[str, Any]]:
    """``(values, scoring start)``: every value of the deployed filter, and ``{"init": start}`` when the
    run's start cannot be deployed (truth or an explicit quaternion), else ``{}``."""
    cls = obj._cls
    values = {**cls.defaults, **obj.fixed, **{k: v for k, v in params.items() if k in cls.defaults}}
    values = cls(**values).values  # validated and normalised as the filter holds them
    scoring: dict[str, Any] = {}
    if "init" in values:
        start = _start(obj, values)
        if isinstance(start, str) and start in ("accmag", "broad"):
            values["init"] = start
        else:
            scoring["init"] = start if isinstance(start, str) else [float(x) for x in start]
            values["init"] = "accmag"
    return dict(values), scoring


def filter_deployment(obj: Any, params: Mapping[str, Any]) -> Deployment:
    """The deployment of ``params`` (:func:`tuner.deployment.build_deployment`)."""
    cls = obj._cls
    values, start = deployed_values(obj, params)
    desc = obj.describe()
    scoring = {"metric": obj.metric, "metric_options": dict(obj.metric_options), "warmup_s": obj.warmup_s,
               "q0": obj.q0 if isinstance(obj.q0, str) else [float(x) for x in obj.q0], **start,
               "data": desc.get("data")}
    if obj.prior:
        scoring["prior"] = dict(obj.prior)
    notes, sources = [], {}
    if "init" in values and "init" not in params and "init" not in obj.fixed and values["init"] != "accmag":
        sources["init"] = "fixed"  # objective.q0 chose the start
    if start:
        sources["init"] = "fixed"
        notes.append(LIVE_START_NOTE.format(start=start["init"]))
    choices = {}
    if "init" in cls.decl.names() and cls.decl["init"].choices:  # what a deployed filter can do without truth
        choices["init"] = [c for c in cls.decl["init"].choices if c not in ("truth", "auto")]
    rate, _ = obj.sample_rate()
    return build_deployment("filter", obj.filter, values, searched=params, fixed=obj.fixed, decl=cls.decl,
                            scoring=scoring, sample_rate_hz=rate, notes=notes, sources=sources, choices=choices)


def filter_build(obj: Any, params: Mapping[str, Any]) -> Any:
    """The deployed filter instance of ``params`` (runs on live data: no start from truth)."""
    values, _ = deployed_values(obj, params)
    return obj._cls(**values)
