"""Objective kinds by YAML name (``objective.kind``), registered by the packages that provide them.

A package adds kinds through the entry-point group ``tuner.objectives`` of its ``pyproject.toml``::

    [project.entry-points."tuner.objectives"]
    filter = "objectives.attitude.objective:FilterObjective"

(the name is the kind, the value a class or factory with ``from_config(section, base_dir)``). The
engine itself registers only the generic ``python`` kind (:mod:`tuner.python_objective`), by the same
``"module:attr"`` spec. Entry points are loaded on first use, so
``tuner list optimizers`` imports no domain code. A name registered twice (two packages, or a
package and the engine) is refused with both sources in the message.

A factory raises ``ValueError`` whose message starts with the key path it complains about
(``objective.filter: unknown filter 'x'; known: ...``). A kind class may also offer a classmethod
``catalog() -> {section: [names]}`` (filters, controllers, metrics, data...) listed by ``tuner list``,
and ``explain(name) -> dict | None`` (parameters, bounds, units, equations) shown by ``tuner describe``.
"""

from __future__ import annotations

import importlib
import sys
from collections.abc import Mapping
from importlib.metadata import entry_points
from pathlib import Path
from typing import Any

__all__ = ["ENTRY_POINT_GROUP", "ENGINE_KEYS", "RegistryError", "Registry", "REGISTRY",
           "build_objective", "resolve_callable"]

ENTRY_POINT_GROUP = "tuner.objectives"
#: keys of the ``objective:`` section the engine consumes itself (not passed to the kind's factory)
ENGINE_KEYS = {"timeout_s": "seconds after which one evaluation is stopped and recorded as failed"}


class RegistryError(ValueError):
    """A kind that cannot be registered or loaded (name collision, broken entry point)."""


def resolve_callable(spec: str, base_dir: str | Path | None = None) -> Any:
    """``"package.module:attr.sub"`` -> the object (``ImportError``/``AttributeError`` if missing).

    With ``base_dir`` (a config's folder) that folder is searched first, so a module next to the config
    imports without ``PYTHONPATH``.
    """
    module, _, attr = spec.partition(":")
    if base_dir is not None:
        d = str(Path(base_dir).resolve())
        if d not in sys.path:
            sys.path.insert(0, d)
    obj = importlib.import_module(module)
    for part in attr.split("."):
        obj = getattr(obj, part)
    return obj


def say_imports(objective: Mapping[str, Any], source: Any) -> None:
    """Tell on stderr that a ``kind: python`` objective is about to be imported and run (by ``run``,
    ``resume``, ``evaluate`` and ``cv``; the read-only commands never build it)."""
    if isinstance(objective, Mapping) and objective.get("kind") == "python":
        import sys

        print(f"note: {source}: objective.kind python imports and runs {objective.get('callable')!r}: "
              "trust it as you would the code itself", file=sys.stderr, flush=True)


class Registry:
    """Kind name -> factory, filled from entry points on first use and by :meth:`register`."""

    def __init__(self, group: str = ENTRY_POINT_GROUP):
        self.group = group
        self._specs: dict[str, tuple[Any, str]] = {}  # kind -> (factory or "module:attr", source)
        self._loaded = False

    def register(self, kind: str, factory: Any, source: str = "") -> None:
        """Add ``kind``; a name already registered is a :class:`RegistryError` naming both sources."""
        if not isinstance(kind, str) or not kind.isidentifier():
            raise RegistryError(f"objective kind names are identifiers, got {kind!r}")
        source = source or (factory if isinstance(factory, str) else getattr(factory, "__module__", "?"))
        if kind in self._specs:
            raise RegistryError(f"objective kind {kind!r} is registered twice: by {self._specs[kind][1]} "
                                f"and by {source}; uninstall one of them")
        self._specs[kind] = (factory, source)

    def _load_entry_points(self) -> None:
        if self._loaded:
            return
        self._loaded = True
        seen: dict[str, str] = {}
        for ep in entry_points(group=self.group):
            dist = getattr(getattr(ep, "dist", None), "name", "?")
            where = f"{dist} ({ep.value})"
            if ep.name in seen and seen[ep.name] == where:  # one distribution seen on two sys.path entries
                continue
            seen[ep.name] = where
            self.register(ep.name, ep.value, where)

    def kinds(self) -> dict[str, str]:
        """Registered kinds and where each comes from."""
        self._load_entry_points()
        return {k: src for k, (_, src) in sorted(self._specs.items())}

    def get(self, kind: str) -> Any:
        """The factory of ``kind`` (imported now); unknown kinds list the registered ones."""
        self._load_entry_points()
        if kind not in self._specs:
            known = sorted(self._specs)
            hint = "" if set(known) - {"python"} else (
                f"; no domain package registered its kinds (entry-point group {self.group!r}): "
                "reinstall it, e.g. `python -m pip install -e .`")
            raise RegistryError(f"objective.kind: unknown kind {kind!r}; allowed: {known}{hint}")
        factory, source = self._specs[kind]
        if isinstance(factory, str):
            try:
                factory = resolve_callable(factory)
            except (ImportError, AttributeError) as exc:
                raise RegistryError(f"objective.kind: {kind!r} is registered by {source} but does not "
                                    f"import: {exc}") from None
            self._specs[kind] = (factory, source)
        return factory

    def catalog(self) -> dict[str, tuple[str, list[str]]]:
        """``{section: (kinds, names)}`` from each kind's optional ``catalog()`` classmethod.

        A section several kinds list (``metrics``, ``data``) joins their names; ``kinds`` is then
        ``"filter, closed_loop"``.
        """
        out: dict[str, tuple[str, list[str]]] = {}
        for kind, sections in self.catalogs().items():
            for section, names in sections.items():
                kinds, have = out.get(section, ("", []))
                out[section] = (f"{kinds}, {kind}" if kinds else kind, sorted({*have, *names}))
        return out

    def catalogs(self) -> dict[str, dict[str, list[str]]]:
        """``{kind: {section: names}}``: each kind's own ``catalog()`` (kinds without one are left out)."""
        out: dict[str, dict[str, list[str]]] = {}
        for kind in self.kinds():
            fn = getattr(self.get(kind), "catalog", None)
            if callable(fn):
                out[kind] = {section: sorted(names) for section, names in dict(fn()).items()}
        return out

    def explain(self, name: str) -> list[tuple[str, dict[str, Any]]]:
        """``[(kind, description)]`` from each kind's optional ``explain(name)`` classmethod (a dict
        with ``section``, ``name``, ``summary``, ``params``; ``None`` when the kind does not know it)."""
        out = []
        for kind in self.kinds():
            fn = getattr(self.get(kind), "explain", None)
            if callable(fn):
                d = fn(name)
                if d is not None:
                    out.append((kind, dict(d)))
        return out

    def build(self, section: Mapping[str, Any], base_dir: Path | None = None) -> Any:
        """Build the objective of a config's ``objective`` section (validated by its factory).

        Engine keys (:data:`ENGINE_KEYS`) are removed before the factory sees the section.
        """
        kind = section.get("kind")
        if not isinstance(kind, str):
            raise RegistryError(f"objective.kind: expected a name, got {kind!r}; allowed: {sorted(self.kinds())}")
        factory = self.get(kind)
        body = {k: v for k, v in section.items() if k not in ENGINE_KEYS}
        try:
            return factory.from_config(body, Path(base_dir) if base_dir else Path.cwd())
        except (TypeError, OverflowError) as exc:  # a value of the wrong type or size in the section
            raise ValueError(f"objective: a value of the wrong type or size ({exc}); `tuner describe "
                             f"{kind}` lists the keys") from None


#: the process-wide registry (the engine's own ``python`` kind plus every installed entry point)
REGISTRY = Registry()
REGISTRY.register("python", "tuner.python_objective:PythonObjective", "tuner (built in)")


def build_objective(section: Mapping[str, Any], base_dir: Path | None = None) -> Any:
    """:meth:`Registry.build` on the process-wide :data:`REGISTRY`."""
    return REGISTRY.build(section, base_dir)
