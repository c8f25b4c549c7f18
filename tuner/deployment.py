"""What a run deploys: the one complete configuration of the tuned filter or controller.

A run's result is not only the searched values: the deployed system is defined by

- the **searched** values (the best point of the run),
- every **fixed** value, wherever the config wrote it (``objective.fixed``, ``parameters: {x: {fixed:
  v}}`` or a bare ``parameters: {x: v}``),
- the **defaults** of everything else, which the deployed system relies on just as much.

:class:`Deployment` holds all of them in ``values`` (``sources`` says which is which), with units and
docs, apart from the settings that only serve **scoring** (a start orientation taken from the ground
truth, the warm-up left out of the metric, the metric and its options, the data, a closed loop's
plant and profile): ``scoring`` records them and nothing exports them as part of the filter or
controller. The objective supplies it through its optional hook ``deployment(params)``
(:class:`tuner.objective.TunableObjective`); an objective without the hook deploys its parameters as
they are. ``best.yaml`` holds it under ``deployment:``; :func:`load_deployment` reads it back.
"""

from __future__ import annotations

import math
from collections.abc import Collection, Iterable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from tuner.objective import hook
from tuner.records import plain

__all__ = ["Deployment", "SOURCES", "DEFAULTS_MEANING", "as_deployment", "attach_deployment", "build_deployment",
           "defaults_baseline", "deployment_for", "load_best", "load_deployment", "param_annotations"]

#: where a value of :attr:`Deployment.values` comes from
SOURCES = ("searched", "fixed", "default")


@dataclass(frozen=True)
class Deployment:
    """The complete configuration of a tuned filter or controller (see the module docstring).

    Attributes
    ----------
    kind : str
        What is deployed: ``"filter"``, ``"closed_loop"`` (a controller), ``"function"``, ``"python"``.
    name : str
        The filter or controller name (``"madgwick"``, ``"protective_fuzzy"``); the function or
        callable for the other kinds.
    values : Mapping[str, Any]
        Every value that defines the deployed filter or controller, ``{name: value}``: constructing the
        filter (controller) from exactly these gives the tuned one.
    units, docs : Mapping[str, str]
        Unit and one-line doc of each value, where the objective declares them.
    sources : Mapping[str, str]
        ``searched``, ``fixed`` or ``default`` for each value (:data:`SOURCES`).
    choices : Mapping[str, list]
        The allowed values of each option with a fixed set of choices (C exports them as ``#define``s).
    scoring : Mapping[str, Any]
        Settings that only served scoring the run (e.g. ``init: truth``, ``warmup_s``, the metric, the
        data); never part of the deployed system.
    sample_rate_hz : float or None
        The rate per-sample values assume (None when unknown or irrelevant).
    notes : tuple[str, ...]
        What a user of the deployed system must know (e.g. how it starts on live data).
    tables : Mapping[str, Any]
        The objective's ``export_tables`` of ``values`` as the run computed them (look-up tables, gains,
        difference equations: ``{name: {"table": nested lists, "doc", "unit", "x_range"/"y_range"}}``), so an
        export writes them without rebuilding the objective (which may need code it never loads).
    """

    kind: str
    name: str
    values: Mapping[str, Any]
    units: Mapping[str, str] = field(default_factory=dict)
    docs: Mapping[str, str] = field(default_factory=dict)
    sources: Mapping[str, str] = field(default_factory=dict)
    choices: Mapping[str, list] = field(default_factory=dict)
    scoring: Mapping[str, Any] = field(default_factory=dict)
    sample_rate_hz: float | None = None
    notes: tuple[str, ...] = ()
    tables: Mapping[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if not isinstance(self.kind, str) or not self.kind:
            raise ValueError(f"deployment.kind: expected a non-empty string, got {self.kind!r}")
        if not isinstance(self.values, Mapping):
            raise ValueError(f"deployment.values: expected a mapping, got {type(self.values).__name__}")
        bad = {k: s for k, s in self.sources.items() if s not in SOURCES}
        if bad:
            raise ValueError(f"deployment.sources: {bad} not in {list(SOURCES)}")
        extra = sorted(set(self.sources) - set(self.values))
        if extra:
            raise ValueError(f"deployment.sources: {extra} name no value")
        for k, options in self.choices.items():  # a value outside its choices has no C enum: never silently
            if k in self.values and isinstance(options, (list, tuple)) and self.values[k] not in options:
                raise ValueError(f"deployment.values.{k}: {self.values[k]!r} is not one of its choices {list(options)}")
        rate = self.sample_rate_hz
        if rate is not None and not (isinstance(rate, (int, float)) and math.isfinite(rate) and rate > 0):
            raise ValueError(f"deployment.sample_rate_hz: expected a positive number or null, got {rate!r}")

    def names(self, source: str) -> list[str]:
        """Names of the values from ``source`` (``searched``, ``fixed`` or ``default``), in order."""
        if source not in SOURCES:
            raise ValueError(f"source: expected one of {list(SOURCES)}, got {source!r}")
        return [k for k in self.values if self.sources.get(k) == source]

    def to_doc(self) -> dict[str, Any]:
        """Plain YAML/JSON data (the ``deployment:`` section of ``best.yaml`` and of every export)."""
        doc: dict[str, Any] = {"kind": self.kind, "name": self.name, "values": dict(self.values),
                               "sources": dict(self.sources), "units": dict(self.units), "docs": dict(self.docs)}
        if self.choices:
            doc["choices"] = {k: list(v) for k, v in self.choices.items()}
        doc["scoring"] = dict(self.scoring)
        doc["sample_rate_hz"] = self.sample_rate_hz
        if self.notes:
            doc["notes"] = list(self.notes)
        if self.tables:
            doc["tables"] = dict(self.tables)
        return plain(doc)

    @classmethod
    def from_doc(cls, doc: Any, where: str = "deployment") -> Deployment:
        """Read :meth:`to_doc` back; ``ValueError`` naming ``where`` and the key when malformed."""
        if not isinstance(doc, Mapping):
            raise ValueError(f"{where}: expected a mapping, got {type(doc).__name__}")
        for key in ("kind", "values"):
            if key not in doc:
                raise ValueError(f"{where}.{key}: missing")
        maps = {}
        for key in ("values", "units", "docs", "sources", "choices", "scoring", "tables"):
            v = doc.get(key) or {}
            if not isinstance(v, Mapping):
                raise ValueError(f"{where}.{key}: expected a mapping, got {v!r}")
            maps[key] = dict(v)
        unknown = sorted(set(doc) - {"kind", "name", "sample_rate_hz", "notes", *maps})
        if unknown:
            raise ValueError(f"{where}.{unknown[0]}: unknown key")
        try:
            return cls(str(doc["kind"]), str(doc.get("name") or ""), sample_rate_hz=doc.get("sample_rate_hz"),
                       notes=tuple(str(n) for n in doc.get("notes") or ()), **maps)
        except ValueError as exc:
            raise ValueError(f"{where}: {exc}") from None


def param_annotations(decl: Any) -> tuple[dict[str, str], dict[str, str], dict[str, list]]:
    """``(units, docs, choices)`` of a parameter declaration (items with ``name``, ``unit``, ``doc``,
    ``choices``; None for none): the parameters that have a unit, a doc line, or string choices."""
    units: dict[str, str] = {}
    docs: dict[str, str] = {}
    choices: dict[str, list] = {}
    for p in (decl or ()):
        if p.unit:
            units[p.name] = p.unit
        if p.doc:
            docs[p.name] = p.doc
        if p.choices and all(isinstance(c, str) for c in p.choices):
            choices[p.name] = list(p.choices)
    return units, docs, choices


def build_deployment(kind: str, name: str, values: Mapping[str, Any], *, searched: Collection[str] = (),
                     fixed: Collection[str] = (), decl: Iterable[Any] | None = None,
                     scoring: Mapping[str, Any] | None = None, sample_rate_hz: float | None = None,
                     notes: Iterable[str] = (), sources: Mapping[str, str] | None = None,
                     choices: Mapping[str, list] | None = None) -> Deployment:
    """The :class:`Deployment` of a ``deployment`` hook: the one way an objective states what it deploys.

    Parameters
    ----------
    kind, name : str
        What is deployed (``"filter"``, ``"closed_loop"``...) and its name (``"madgwick"``, ``"pid"``).
    values : mapping
        Every value of the deployed system (searched, fixed and defaults), in the order it declares them.
    searched, fixed : collections of names
        Each value's source is ``searched`` if its name is in ``searched``, else ``fixed`` if in ``fixed``,
        else ``default`` (:data:`SOURCES`); ``sources`` overrides single entries.
    decl : iterable of parameter declarations, optional
        Units, one-line docs and string choices of the values (:func:`param_annotations`); ``choices``
        overrides single entries (e.g. the choices a deployed system has without ground truth).
    scoring, sample_rate_hz, notes
        As in :class:`Deployment`. Every field is made YAML/JSON-native (:func:`tuner.records.plain`).
    """
    sources_ = {k: "searched" if k in searched else "fixed" if k in fixed else "default" for k in values}
    units, docs, choices_ = param_annotations(decl)
    return Deployment(str(kind), str(name), plain(dict(values)), units=units, docs=docs,
                      sources={**sources_, **dict(sources or {})}, choices=plain({**choices_, **dict(choices or {})}),
                      scoring=plain(dict(scoring or {})), sample_rate_hz=plain(sample_rate_hz),
                      notes=tuple(str(n) for n in notes))


def as_deployment(value: Deployment | Mapping[str, Any], where: str = "deployment") -> Deployment:
    """A :class:`Deployment` from itself or from the dict a ``deployment`` hook returns."""
    return value if isinstance(value, Deployment) else Deployment.from_doc(value, where)


def deployment_for(objective: Any, params: Mapping[str, Any], searched: Collection[str] | None = None,
                   fixed: Collection[str] = ()) -> Deployment:
    """The deployment of ``params`` under ``objective``.

    Uses the objective's ``deployment`` hook; without it the parameters are the whole deployment (kind
    and name from ``describe()`` where it exists). ``searched`` and ``fixed`` are the run's search space's
    free and fixed names: they override the hook's ``sources`` (the objective cannot know which of the
    values it was handed were searched).
    """
    fn = hook(objective, "deployment")
    if fn is not None:
        dep = as_deployment(fn(dict(params)))
    else:
        describe = hook(objective, "describe")
        obj = dict((describe() or {}).get("objective") or {}) if describe is not None else {}
        kind = str(obj.get("kind") or getattr(objective, "kind", "") or "python")
        name = str(obj.get("function") or obj.get("callable") or obj.get("name") or getattr(objective, "__name__", ""))
        rate_fn = hook(objective, "sample_rate")
        rate = rate_fn()[0] if rate_fn is not None else None
        dep = build_deployment(kind, name, params, searched=params, sample_rate_hz=rate)
    if searched is None and not fixed:
        return dep
    sources = dict(dep.sources)
    for k in dep.values:
        if searched is not None and k in searched:
            sources[k] = "searched"
        elif k in fixed:
            sources[k] = "fixed"
        elif searched is not None and sources.get(k) == "searched":
            sources[k] = "fixed"  # handed in by the run but not searched: a value of the space's fixed part
    return Deployment(dep.kind, dep.name, dep.values, dep.units, dep.docs, sources, dep.choices, dep.scoring,
                      dep.sample_rate_hz, dep.notes, dep.tables)


def load_deployment(run_dir: str | Path) -> Deployment:
    """The deployment of a finished run: ``best.yaml``'s ``deployment:``, else rebuilt from its config.

    Runs written before ``best.yaml`` held the deployment are rebuilt from their resolved config and
    best parameters (the objective must still build). Raises :class:`tuner.records.RunError` naming the
    file when the run has no best or a malformed deployment.
    """
    from tuner.records import RunError
    from tuner.rundir import RunDir

    rd = RunDir(run_dir)
    best = rd.best()
    if best.deployment.get("error"):
        raise RunError(f"{rd.file('best.yaml')}: deployment: could not be built: {best.deployment['error']}")
    if best.deployment:
        try:
            return Deployment.from_doc(best.deployment, "deployment")
        except ValueError as exc:
            raise RunError(f"{rd.file('best.yaml')}: {exc}") from None
    from tuner.config import ConfigError
    from tuner.setup import run_objective

    try:
        _, objective, space = run_objective(rd)
    except (ConfigError, ValueError, OSError, ImportError) as exc:
        raise RunError(f"{rd.file('best.yaml')}: no deployment recorded and the objective does not "
                       f"rebuild from config.yaml: {exc}") from None
    return deployment_for(objective, {**space.fixed, **best.params}, space.free_names, list(space.fixed))


def load_best(run_dir: str | Path) -> dict[str, Any]:
    """Every value of the run's deployed filter or controller (``load_deployment(run_dir).values``)."""
    return dict(load_deployment(run_dir).values)


def attach_deployment(best: Any, objective: Any, space: Any) -> Any:
    """``best`` (a :class:`tuner.records.Best`) with its deployment under ``objective`` and ``space``.

    A deployment that cannot be built (the hook raises ``ValueError`` or ``TypeError``) is recorded as
    ``{"error": text}``, so the finished run is kept and :func:`load_deployment` says why it has none.
    """
    import dataclasses

    try:
        dep = deployment_for(objective, {**space.fixed, **best.params}, space.free_names, list(space.fixed))
        tables_fn = hook(objective, "export_tables")
        if tables_fn is not None:
            try:
                tables = tables_fn(dict(dep.values))
            except (ValueError, TypeError, ArithmeticError):  # a design without tables: the values still deploy
                tables = None
            dep = dataclasses.replace(dep, tables=plain(dict(tables or {})))
        doc = dep.to_doc()
    except (ValueError, TypeError) as exc:
        doc = {"error": f"{type(exc).__name__}: {exc}"}
    return dataclasses.replace(best, deployment=doc)


#: what every "defaults" baseline means (cv.md, validation, reports say it in these words)
DEFAULTS_MEANING = ("defaults: the config's fixed values (objective.fixed and parameters' fixed values alike) "
                    "with the searched parameters at the objective's defaults")


def defaults_baseline(objective: Any, space: Any) -> dict[str, Any] | None:
    """The one "defaults" baseline (:data:`DEFAULTS_MEANING`): the objective's ``default_params`` (its
    defaults with ``objective.fixed`` applied) overridden by the space's fixed values, so a value fixed
    under ``parameters:`` counts as one fixed under ``objective.fixed``. None without the hook."""
    fn = hook(objective, "default_params")
    if fn is None:
        return None
    return {**dict(fn()), **dict(space.fixed)}
