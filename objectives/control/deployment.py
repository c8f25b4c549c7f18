"""The closed-loop objective's ``deployment`` hook: the complete tuned controller, for every plant.

The deployed controller is defined by every value of its declaration (searched, fixed, defaults) and
by the period it runs at (``sample_rate_hz``). The plant, the reference (profile or scenario), the cost,
the requirements and the sensor noise only serve scoring the run in simulation: they go under
``scoring`` (the loop's :meth:`scoring`). A design that depends on the plant (LQR linearises the model,
a discrete PID depends on the period) is exported with its resulting coefficients by ``export_tables``.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from tuner.deployment import Deployment, build_deployment

__all__ = ["controller_deployment"]


def controller_deployment(obj: Any, params: Mapping[str, Any]) -> Deployment:
    """The deployment of ``params`` (:func:`tuner.deployment.build_deployment`)."""
    return build_deployment("closed_loop", obj.controller, obj.values(params), searched=params, fixed=obj.fixed,
                            decl=obj.decl, scoring=obj.loop.scoring(), sample_rate_hz=1.0 / float(obj.loop.period_s),
                            notes=obj.loop.notes())
