"""Controllers of the wheeled mobile pendulum and their registry.

``CONTROLLERS`` maps the YAML name (``controller: pid``) to ``"module:Class"``; classes are imported
lazily so that the plant kernel (which imports :mod:`.kernels`) and the controllers (which import the
plant for their design) do not import each other at package import time.

To add a controller: write its numba step and ``KIND_*`` branch in :mod:`.kernels` (see the
docstring there), its :class:`.base.Controller` subclass in its own module, and one line here. The
names ``flc``, ``protective_fuzzy`` and ``lut`` are reserved for ``controllers/fuzzy.py``.
"""

from __future__ import annotations

import importlib

__all__ = ["CONTROLLERS", "get_controller"]

CONTROLLERS: dict[str, str] = {
    "lqr": "objectives.control.controllers.lqr:LQR",
    "lqg": "objectives.control.controllers.lqr:LQG",
    "pid": "objectives.control.controllers.pid:PID",
    "flc": "objectives.control.controllers.fuzzy:FLC",
    "protective_fuzzy": "objectives.control.controllers.fuzzy:ProtectiveFuzzy",
    "lut": "objectives.control.controllers.fuzzy:LUTFuzzy",
}


def get_controller(name: str):
    """The controller class registered as ``name`` (``ValueError`` listing known names otherwise)."""
    try:
        target = CONTROLLERS[name]
    except KeyError:
        raise ValueError(f"unknown controller {name!r}; known: {sorted(CONTROLLERS)}") from None
    module, cls = target.split(":")
    return getattr(importlib.import_module(module), cls)
