"""YAML names of objectives (``objective.kind``) and how to build them.

Each kind maps to a factory ``from_config(section: dict, base_dir: Path) -> objective``; a factory
raises ``ValueError`` whose message starts with the key path it complains about. A user's own
objective is ``{kind: python, callable: "package.module:function", ...}``: the function receives the
params dict (and must be importable on every worker).
"""

from __future__ import annotations

import importlib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

__all__ = ["OBJECTIVE_KINDS", "build_objective", "PythonObjective"]

OBJECTIVE_KINDS: dict[str, str] = {
    "function": "objectives.functions:FunctionObjective",
    "filter": "objectives.attitude.objective:FilterObjective",
    "closed_loop": "objectives.control.objective:ClosedLoopObjective",
    "python": "objectives.registry:PythonObjective",
}


def _resolve(spec: str) -> Any:
    module, _, attr = spec.partition(":")
    obj = importlib.import_module(module)
    for part in attr.split("."):
        obj = getattr(obj, part)
    return obj


@dataclass(frozen=True)
class PythonObjective:
    """A user callable ``module:function`` as an objective; ``options`` are passed as keywords."""

    callable: str
    options: dict = field(default_factory=dict)

    @classmethod
    def from_config(cls, section: dict[str, Any], base_dir: Path | None = None) -> PythonObjective:
        if "callable" not in section or ":" not in str(section["callable"]):
            raise ValueError("objective.callable: expected 'package.module:function'")
        unknown = sorted(set(section) - {"kind", "callable", "options"})
        if unknown:
            raise ValueError(f"objective.{unknown[0]}: unknown key; allowed: callable, options")
        try:
            _resolve(section["callable"])
        except (ImportError, AttributeError) as exc:
            raise ValueError(f"objective.callable: cannot import {section['callable']!r} ({exc})") from None
        return cls(section["callable"], dict(section.get("options") or {}))

    def __call__(self, params: dict[str, Any]) -> Any:
        return _resolve(self.callable)(params, **self.options)


def build_objective(section: dict[str, Any], base_dir: Path | None = None) -> Any:
    """Build the objective of a config's ``objective`` section (validated by its factory)."""
    kind = section.get("kind")
    if kind not in OBJECTIVE_KINDS:
        raise ValueError(f"objective.kind: unknown kind {kind!r}; allowed: {sorted(OBJECTIVE_KINDS)}")
    factory = _resolve(OBJECTIVE_KINDS[kind])
    return factory.from_config(dict(section), Path(base_dir) if base_dir else Path.cwd())
