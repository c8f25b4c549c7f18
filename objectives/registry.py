"""Compatibility names: the registry of objective kinds lives in :mod:`tuner.registry`.

The domain kinds (``filter``, ``closed_loop``, ``function``) are registered through the entry-point
group ``tuner.objectives`` in ``pyproject.toml``; this module only re-exports the engine's names.
"""

from __future__ import annotations

from tuner.python_objective import PythonObjective
from tuner.registry import REGISTRY, build_objective

__all__ = ["build_objective", "PythonObjective", "REGISTRY"]
