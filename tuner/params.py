"""One declaration per parameter set: defaults, search bounds, validation, docs and ``describe()``.

The engine's declaration mechanism: the domain's filters and controllers declare with it (through
:mod:`objectives.params`, which re-exports it beside its array validators), and it builds the engine's
search space (:class:`tuner.space.Real`, :class:`tuner.space.Space`).

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

import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from typing import Any, ClassVar, Literal

import numpy as np

from tuner.space import Real, Space

__all__ = [
    "Interval", "Param", "ParamSet", "ANY_REAL", "NONNEG", "POSITIVE", "UNIT_OPEN", "UNIT_CLOSED",
    "check_number", "check_bool", "check_choice", "Declared",
]


@dataclass(frozen=True)
class Interval:
    """Allowed values of a number: ``low <= x <= high`` (strict where ``*_open``), finite unless
    ``allow_inf``."""

    low: float = -math.inf
    high: float = math.inf
    low_open: bool = False
    high_open: bool = False
    allow_inf: bool = False

    def contains(self, x: float) -> bool:
        if math.isnan(x) or (math.isinf(x) and not self.allow_inf):
            return False
        if x < self.low or (self.low_open and x == self.low):
            return False
        return not (x > self.high or (self.high_open and x == self.high))

    def __str__(self) -> str:
        """``in [0, inf)``: brackets say which ends are allowed (inf only with ``allow_inf``)."""
        lo = "(" if self.low_open or (math.isinf(self.low) and not self.allow_inf) else "["
        hi = ")" if self.high_open or (math.isinf(self.high) and not self.allow_inf) else "]"
        return f"in {lo}{self.low:g}, {self.high:g}{hi}"


ANY_REAL = Interval()
NONNEG = Interval(0.0)
POSITIVE = Interval(0.0, low_open=True)
UNIT_OPEN = Interval(0.0, 1.0, low_open=True, high_open=True)
UNIT_CLOSED = Interval(0.0, 1.0)


def _is_number(x: Any) -> bool:
    return not isinstance(x, (bool, np.bool_)) and isinstance(x, (int, float, np.integer, np.floating))


def check_number(owner: str, key: str, x: Any, allowed: Interval = ANY_REAL, unit: str = "",
                 integer: bool = False) -> float | int:
    """``x`` as a float (int when ``integer``); ValueError naming owner, key, value and range otherwise."""
    what = "an integer" if integer else "a number"
    u = f" {unit}" if unit and unit != "1" else ""
    if not _is_number(x) or (integer and not float(x).is_integer()):
        raise ValueError(f"{owner}: {key} must be {what} {allowed}{u}, got {x!r}")
    if not allowed.contains(float(x)):
        raise ValueError(f"{owner}: {key} must be {allowed}{u}, got {x!r}")
    return int(x) if integer else float(x)


def check_bool(owner: str, key: str, x: Any) -> bool:
    """``x`` as a bool; ValueError unless it is ``true`` or ``false``."""
    if not isinstance(x, (bool, np.bool_)):
        raise ValueError(f"{owner}: {key} must be true or false, got {x!r}")
    return bool(x)


def check_choice(owner: str, key: str, x: Any, choices: Iterable[Any]) -> Any:
    """``x`` unchanged when it is one of ``choices``; ValueError listing them otherwise."""
    choices = tuple(choices)
    if isinstance(x, (list, dict, np.ndarray)) or x not in choices:
        raise ValueError(f"{owner}: {key} must be one of {list(choices)}, got {x!r}")
    return x


@dataclass(frozen=True)
class Param:
    """Declaration of one named parameter.

    Parameters
    ----------
    name : str
        The one name of the parameter, from YAML to the kernel call.
    default : any
        Default value (a number, a bool, a string...).
    bounds : (low, high) or None
        Default search bounds in physical units; ``None`` makes the parameter a fixed option of the
        default search space.
    scale : {"linear", "log"}
        Scale of the search.
    unit : str
        Physical unit (``"rad/s"``, ``"1"`` for dimensionless, ``""`` for options without a unit).
    doc : str
        One line describing the parameter.
    eq : str
        The seed paper's equation (or table) the parameter appears in, e.g. ``"report eq. 33"``.
    allowed : Interval
        Valid values of a number (checked at construction).
    choices : tuple or None
        Valid values of an option (strings); ``bool`` defaults make a true/false option.
    integer : bool
        Integer-valued (searched and validated as an integer).
    kind : {"number", "bool", "choice", "any"}
        Derived from ``default``/``choices`` unless given; ``any`` skips the type check (the owner's
        own check validates such structured options).
    nullable : bool
        ``None`` is a valid value too (an optional budget, an unset option whose value the owner derives).
    """

    name: str
    default: Any
    bounds: tuple[float, float] | None = None
    scale: Literal["linear", "log"] = "linear"
    unit: str = ""
    doc: str = ""
    eq: str = ""
    allowed: Interval = ANY_REAL
    choices: tuple[Any, ...] | None = None
    integer: bool = False
    kind: str = ""
    nullable: bool = False

    def __post_init__(self) -> None:
        if not self.kind:
            if self.choices is not None:
                kind = "choice"
            elif isinstance(self.default, (bool, np.bool_)):
                kind = "bool"
            elif _is_number(self.default):
                kind = "number"
            else:
                kind = "any"
            object.__setattr__(self, "kind", kind)
        if self.kind not in ("number", "bool", "choice", "any"):
            raise ValueError(f"{self.name}: kind must be number, bool, choice or any, got {self.kind!r}")
        if self.choices is not None:
            object.__setattr__(self, "choices", tuple(self.choices))
        # the declaration itself must be consistent: default valid, bounds inside the allowed range
        self.check("declaration", self.default)
        if self.bounds is not None:
            lo, hi = self.bounds
            if not (self.allowed.contains(float(lo)) and self.allowed.contains(float(hi))):
                raise ValueError(f"{self.name}: search bounds {self.bounds} outside the allowed range {self.allowed}")

    @property
    def searched(self) -> bool:
        return self.bounds is not None

    def check(self, owner: str, value: Any) -> Any:
        """The validated value (float for numbers); ValueError naming ``owner`` and the key."""
        if value is None and self.nullable:
            return None
        if self.kind == "number":
            return check_number(owner, self.name, value, self.allowed, self.unit, self.integer)
        if self.kind == "bool":
            return check_bool(owner, self.name, value)
        if self.kind == "choice":
            return check_choice(owner, self.name, value, self.choices)
        return value

    def real(self) -> Real:
        """The :class:`tuner.space.Real` of the default search space."""
        if self.bounds is None:
            return Real(self.name, fixed=self.default, unit=self.unit, doc=self.doc)
        return Real(self.name, self.bounds[0], self.bounds[1], scale=self.scale, integer=self.integer,
                    unit=self.unit, doc=self.doc)

    def describe(self) -> dict[str, Any]:
        """Structured description (plain Python values)."""
        d: dict[str, Any] = {"name": self.name, "default": self.default, "kind": self.kind,
                             "unit": self.unit, "doc": self.doc, "eq": self.eq}
        if self.bounds is not None:
            d["bounds"] = (float(self.bounds[0]), float(self.bounds[1]))
            d["scale"] = self.scale
        else:
            d["bounds"] = None
            d["scale"] = None
        if self.kind == "number":
            d["allowed"] = str(self.allowed)
        elif self.kind == "choice":
            d["allowed"] = list(self.choices)
        elif self.kind == "bool":
            d["allowed"] = [True, False]
        else:
            d["allowed"] = None
        if self.integer:
            d["integer"] = True
        if self.nullable:
            d["nullable"] = True
        return d


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
