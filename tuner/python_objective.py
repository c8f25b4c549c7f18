"""The engine's own objective kind, ``kind: python``: a user callable ``module:function``.

Registered in :data:`tuner.registry.REGISTRY` as ``"tuner.python_objective:PythonObjective"`` like any
package's kind. A config naming it is code: it imports and runs the callable, through
:func:`tuner.trust.import_code` (never in a read-only command, never from inside a handed-over run directory).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from tuner.deployment import Deployment, build_deployment
from tuner.trust import import_code

__all__ = ["PythonObjective"]


@dataclass(frozen=True)
class PythonObjective:
    """A user callable ``module:function`` as an objective; ``options`` are passed as keywords.

    ``kind: python`` imports and runs the named code: a config naming it is code, and must be
    trusted like code.
    """

    callable: str
    options: dict = field(default_factory=dict)
    #: the config's folder, searched first for the module (no PYTHONPATH needed)
    base_dir: str | None = None

    @classmethod
    def from_config(cls, section: Mapping[str, Any], base_dir: Path | None = None) -> PythonObjective:
        if "callable" not in section or ":" not in str(section["callable"]):
            raise ValueError("objective.callable: expected 'package.module:function'")
        unknown = sorted(set(section) - {"kind", "callable", "options"})
        if unknown:
            raise ValueError(f"objective.{unknown[0]}: unknown key; allowed: callable, options")
        options = section.get("options") or {}
        if not isinstance(options, Mapping):
            raise ValueError(f"objective.options: expected a mapping of keyword arguments, got {options!r}")
        obj = cls(str(section["callable"]), dict(options), str(base_dir) if base_dir is not None else None)
        obj.preflight()
        return obj

    def preflight(self) -> list[str]:
        """Import the callable (in the process that calls this: the driver, or a Dask worker)."""
        try:
            fn = import_code(self.callable, self.base_dir, "objective.callable")
        except (ImportError, AttributeError) as exc:
            raise ValueError(f"objective.callable: cannot import {self.callable!r} ({exc})") from None
        if not callable(fn):
            raise ValueError(f"objective.callable: {self.callable!r} is a {type(fn).__name__}, not callable")
        return []

    def __call__(self, params: dict[str, Any]) -> Any:
        return import_code(self.callable, self.base_dir, "objective.callable")(params, **self.options)

    def deployment(self, params: Mapping[str, Any]) -> Deployment:
        """The parameters as they are: a user callable declares nothing else."""
        return build_deployment("python", self.callable, params, searched=params,
                                scoring={"options": dict(self.options)})
