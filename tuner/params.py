"""One declaration per parameter set: defaults, search bounds, validation, docs and ``describe()``.

The engine's declaration mechanism: the domain's filters and controllers declare with it (through
:mod:`objectives.params`, which re-exports it beside its array validators), the optimisers declare their
options with it (:mod:`tuner.optimizers.base`), and it builds the engine's search space. :class:`Param`
(with :class:`Interval` and the ``check_*`` validators) lives in :mod:`tuner.space`, because a Param with
``bounds`` is a search dimension (:class:`tuner.space.Real` is a Param written by its bounds) and a
:class:`tuner.space.Space` is built from Params; this module adds the sets (:class:`ParamSet`) and the
:class:`Declared` mixin and re-exports the rest.

A filter or controller lists its parameters once as :class:`Param` entries in a :class:`ParamSet`;
everything else derives from that declaration:

- :meth:`ParamSet.defaults` -- the default value of every parameter;
- :meth:`ParamSet.reals` / :meth:`ParamSet.space` -- the default search space (:class:`tuner.space.Real`):
  parameters with ``bounds`` are searched there, the others are options fixed at their default;
- :meth:`ParamSet.validate` -- the one validation, at construction: unknown names, wrong types and
  values outside the allowed range raise a :class:`ValueError` naming the owner, the key, the bad
  value and what is allowed;
- :meth:`ParamSet.describe` -- structured data (name, default, bounds, scale, unit, doc, the seed
  paper's equation) for documentation and ``tuner describe``.

The search ``bounds`` and the ``allowed`` range are different things: ``beta`` of Madgwick's filter is
searched in [1e-3, 1] rad/s by default but any finite ``beta >= 0`` is a valid filter.

Example
-------
>>> ps = ParamSet("demo", (Param("beta", 0.1, bounds=(1e-3, 1.0), scale="log", unit="rad/s", allowed=NONNEG),
...                        Param("variant", "paper", choices=("paper", "original_c"))))
>>> ps.defaults()
{'beta': 0.1, 'variant': 'paper'}
>>> ps.validate({"beta": 0.2})["beta"]
0.2
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from typing import Any, ClassVar

from tuner.space import (
    ANY_REAL,
    NONNEG,
    POSITIVE,
    UNIT_CLOSED,
    UNIT_OPEN,
    Interval,
    Param,
    Real,
    Space,
    check_bool,
    check_choice,
    check_number,
)

__all__ = [
    "Interval", "Param", "ParamSet", "ANY_REAL", "NONNEG", "POSITIVE", "UNIT_OPEN", "UNIT_CLOSED",
    "check_number", "check_bool", "check_choice", "Declared",
]


@dataclass(frozen=True)
class ParamSet:
    """The ordered, frozen declaration of an owner's parameters (see module docstring)."""

    owner: str
    params: tuple[Param, ...] = field(default=())

    def __post_init__(self) -> None:
        object.__setattr__(self, "params", tuple(self.params))
        names = [p.name for p in self.params]
        dup = sorted({n for n in names if names.count(n) > 1})
        if dup:
            raise ValueError(f"{self.owner}: parameter(s) declared twice: {dup}")

    def __iter__(self):
        return iter(self.params)

    def __getitem__(self, name: str) -> Param:
        found = {p.name: p for p in self.params}.get(name)
        if found is None:
            raise KeyError(name)
        return found

    def names(self) -> list[str]:
        return [p.name for p in self.params]

    def defaults(self) -> dict[str, Any]:
        return {p.name: p.default for p in self.params}

    def reals(self) -> tuple[Real, ...]:
        return tuple(p.real() for p in self.params)

    def space(self) -> Space:
        return Space(self.reals())

    def with_owner(self, owner: str) -> ParamSet:
        return ParamSet(owner, self.params)

    def validate(self, values: Mapping[str, Any] | None = None) -> dict[str, Any]:
        """Defaults updated with ``values``, each value checked once; unknown names raise ValueError."""
        values = dict(values or {})
        unknown = sorted(set(values) - set(self.names()))
        if unknown:
            raise ValueError(f"{self.owner}: unknown parameter(s) {unknown}; known: {sorted(self.names())}")
        out = {}
        for p in self.params:
            out[p.name] = p.check(self.owner, values[p.name]) if p.name in values else p.default
        return out

    def describe(self) -> list[dict[str, Any]]:
        return [p.describe() for p in self.params]

    @classmethod
    def from_space(cls, owner: str, reals: Iterable[Real], defaults: Mapping[str, Any]) -> ParamSet:
        """A declaration built from a legacy ``params`` tuple and ``defaults`` dict (no range check:
        the owner validates those values itself)."""
        out = []
        for r in reals:
            d = defaults.get(r.name, r.fixed if r.is_fixed else None)
            bounds = None if r.is_fixed else (r.low, r.high)
            out.append(Param(r.name, d, bounds, r.scale, r.unit, r.doc, integer=r.integer,
                             kind="any", allowed=Interval(allow_inf=True)))
        return cls(owner, tuple(out))

    def markdown(self) -> str:
        """A Markdown table of the declaration (for docs and ``tuner describe``)."""
        rows = ["| name | default | bounds | scale | unit | allowed | doc | eq. |", "|" + "---|" * 8]
        for d in self.describe():
            b = "fixed" if d["bounds"] is None else f"[{d['bounds'][0]:g}, {d['bounds'][1]:g}]"
            rows.append(f"| {d['name']} | {d['default']!r} | {b} | {d['scale'] or ''} | {d['unit']} | "
                        f"{d['allowed'] if d['allowed'] is not None else ''} | {d['doc']} | {d['eq']} |")
        return "\n".join(rows)


class Declared:
    """Mixin of filters and controllers: ``declaration()`` and ``describe()`` from the class's ``decl``.

    Classes without a ``decl`` (defined outside the package) are described from their hand-written
    ``params`` (a tuple of :class:`tuner.space.Real`) and ``defaults``.
    """

    name: ClassVar[str] = ""
    decl: ClassVar[ParamSet | None] = None
    params: ClassVar[tuple[Real, ...]] = ()
    defaults: ClassVar[dict[str, Any]] = {}

    @classmethod
    def declaration(cls) -> ParamSet:
        """The parameter declaration (built from ``params``/``defaults`` when there is no ``decl``)."""
        if cls.decl is not None:
            return cls.decl
        return ParamSet.from_space(cls.name, cls.params, cls.defaults)

    @classmethod
    def _describe_extra(cls) -> dict[str, Any]:
        return {}

    @classmethod
    def describe(cls) -> dict[str, Any]:
        """Structured description: name, class, summary and every parameter with default, bounds,
        scale, unit, allowed values, doc and the seed's equation or table (plus class-specific facts)."""
        doc = (cls.__doc__ or "").strip().splitlines()
        return {"name": cls.name, "class": f"{cls.__module__}.{cls.__qualname__}",
                "summary": doc[0] if doc else "", **cls._describe_extra(), "params": cls.declaration().describe()}
