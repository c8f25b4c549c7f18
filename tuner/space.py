"""Parameter spaces: named parameters, their bounds and scales, and the unit-cube encoding.

Optimisers only ever see points of the unit cube ``[0, 1]^d`` where ``d`` is the number of free
parameters; :class:`Space` alone knows physical units, log scales, integers and fixed values.

One class declares a parameter and is a search dimension: :class:`Param` (name, default, bounds, scale,
unit, doc, allowed values; validated at construction). A Param with ``bounds`` is searched, one without is
fixed at its default; :class:`Real` is the Param written by its bounds, as a job's ``parameters:`` section
writes it. :mod:`tuner.params` groups Params into declarations (``ParamSet``).

Example
-------
>>> space = Space([Real("beta", 1e-3, 1.0, scale="log"), Real("n", 1, 9, integer=True),
...                Real("variant", fixed="paper")])
>>> space.dim
2
>>> space.decode([0.5, 1.0])
{'beta': 0.031622776601683794, 'n': 9, 'variant': 'paper'}
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np

__all__ = ["Real", "Space", "SpaceError", "Param", "Interval", "ANY_REAL", "NONNEG", "POSITIVE", "UNIT_OPEN",
           "UNIT_CLOSED", "check_number", "check_bool", "check_choice"]


class SpaceError(ValueError):
    """A parameter declaration or a value that does not fit its declaration."""


_MISSING = object()


def _check_name(name: Any) -> None:
    if not isinstance(name, str) or not name.isidentifier():
        raise SpaceError(f"parameter name must be an identifier, got {name!r}")


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
    """Declaration of one named parameter; with ``bounds`` it is a search dimension too.

    A :class:`Space` is built from Params: one with ``bounds`` is searched there (:meth:`to_unit` /
    :meth:`from_unit` map it to the unit interval, on its ``scale``), one without is fixed at its
    ``default``. :class:`Real` writes the same object by its bounds, as a job's ``parameters:`` does.

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
        _check_name(self.name)
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
            lo, hi = self._dimension()
            if not (self.allowed.contains(lo) and self.allowed.contains(hi)):
                raise ValueError(f"{self.name}: search bounds {self.bounds} outside the allowed range {self.allowed}")

    def _dimension(self) -> tuple[float, float]:
        """The bounds as floats, checked as a search dimension (:class:`SpaceError` naming the bad values)."""
        if self.scale not in ("linear", "log"):
            raise SpaceError(f"{self.name}: scale must be 'linear' or 'log', got {self.scale!r}")
        low, high = self.bounds
        try:
            low, high = float(low), float(high)
        except (TypeError, ValueError):
            raise SpaceError(f"{self.name}: low and high must be numbers, got low={low!r}, high={high!r}") from None
        if not (math.isfinite(low) and math.isfinite(high) and low < high):
            raise SpaceError(f"{self.name}: need finite low < high, got low={low}, high={high}")
        if self.scale == "log" and low <= 0:
            raise SpaceError(f"{self.name}: log scale needs low > 0, got low={low}")
        if self.integer and math.floor(high) < math.ceil(low):
            raise SpaceError(f"{self.name}: integer parameter has no integer in [{low}, {high}]")
        return low, high

    @property
    def searched(self) -> bool:
        return self.bounds is not None

    # --- as a search dimension -----------------------------------------------------------------
    @property
    def is_fixed(self) -> bool:
        """Not searched: the parameter always takes its ``default`` (:attr:`fixed`)."""
        return self.bounds is None

    @property
    def fixed(self) -> Any:
        """The value of a fixed parameter (a sentinel for a searched one)."""
        return self.default if self.bounds is None else _MISSING

    @property
    def low(self) -> float:
        return math.nan if self.bounds is None else float(self.bounds[0])

    @property
    def high(self) -> float:
        return math.nan if self.bounds is None else float(self.bounds[1])

    def to_unit(self, value: float) -> float:
        """Physical value -> unit interval (clipped into [0, 1])."""
        v = float(value)
        if self.scale == "log":
            if v <= 0:
                raise SpaceError(f"{self.name}: log-scale value must be > 0, got {value!r}")
            u = (math.log10(v) - math.log10(self.low)) / (math.log10(self.high) - math.log10(self.low))
        else:
            u = (v - self.low) / (self.high - self.low)
        return min(1.0, max(0.0, u))

    def from_unit(self, u: float) -> float | int:
        """Unit interval -> physical value (``u`` is clipped into [0, 1] first)."""
        u = min(1.0, max(0.0, float(u)))
        lo_, hi_ = self.low, self.high
        if self.scale == "log":
            lo, hi = math.log10(lo_), math.log10(hi_)
            v = 10.0 ** (lo + u * (hi - lo))
        else:
            v = lo_ + u * (hi_ - lo_)
        v = min(hi_, max(lo_, v))
        if self.integer:
            return int(min(math.floor(hi_), max(math.ceil(lo_), round(v))))
        return v

    def contains(self, value: Any) -> bool:
        """Whether ``value`` lies in the search bounds (equals the fixed value)."""
        if self.is_fixed:
            return value == self.fixed
        try:
            v = float(value)
        except (TypeError, ValueError):
            return False
        return self.low <= v <= self.high and (not self.integer or float(v).is_integer())

    def to_dict(self) -> dict[str, Any]:
        """YAML-native form of the dimension, the inverse of :meth:`Real.from_dict`."""
        if self.is_fixed:
            d: dict[str, Any] = {"fixed": _plain(self.fixed)}
        else:
            d = {"low": self.low, "high": self.high}
            if self.scale != "linear":
                d["scale"] = self.scale
            if self.integer:
                d["integer"] = True
        if self.unit:
            d["unit"] = self.unit
        if self.doc:
            d["doc"] = self.doc
        return d

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
        """This parameter as the dimension of a default search space (its bounds and text, not the declaration's
        default, allowed range and equation): the :class:`Real` a job's ``parameters:`` would write."""
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


class Real(Param):
    """One search dimension written by its bounds (or a fixed value): a :class:`Param` whose default is
    its fixed value (``None`` when searched), as a job's ``parameters:`` section writes it.

    Parameters
    ----------
    name : str
        Identifier used in YAML, history columns and exported files.
    low, high : float
        Inclusive bounds in physical units; finite, ``low < high``. Ignored for fixed parameters.
    scale : {"linear", "log"}
        ``log`` searches ``log10(value)`` uniformly; needs ``low > 0``.
    integer : bool
        Round decoded values to the nearest integer (bounds must then contain an integer).
    fixed : any
        If given, the parameter is not searched: it always takes this value (a number, a string,
        a list...). Fixed parameters occupy no dimension of the unit cube.
    unit : str
        Free text, for documentation and reports (``"rad/s"``, ``"1"``).
    doc : str
        One line describing the parameter.
    """

    def __init__(self, name: str, low: float = math.nan, high: float = math.nan,
                 scale: Literal["linear", "log"] = "linear", integer: bool = False, fixed: Any = _MISSING,
                 unit: str = "", doc: str = ""):
        _check_name(name)
        if fixed is not _MISSING:
            super().__init__(name, fixed, None, scale, unit, doc, integer=integer, kind="any")
            return
        if scale not in ("linear", "log"):
            raise SpaceError(f"{name}: scale must be 'linear' or 'log', got {scale!r}")
        try:
            low, high = float(low), float(high)
        except (TypeError, ValueError):
            raise SpaceError(f"{name}: low and high must be numbers, got low={low!r}, high={high!r}") from None
        super().__init__(name, None, (low, high), scale, unit, doc, integer=integer, kind="any")

    def __repr__(self) -> str:
        if self.is_fixed:
            return f"Real({self.name!r}, fixed={self.fixed!r})"
        extra = f", scale={self.scale!r}" if self.scale != "linear" else ""
        extra += ", integer=True" if self.integer else ""
        return f"Real({self.name!r}, {self.low!r}, {self.high!r}{extra})"

    @classmethod
    def from_dict(cls, name: str, spec: Any) -> Real:
        """Build from YAML: ``{low, high, scale?, integer?}``, ``{fixed: v}`` or a bare value (fixed)."""
        if not isinstance(spec, Mapping):
            return cls(name, fixed=spec)
        allowed = {"low", "high", "scale", "integer", "fixed", "unit", "doc"}
        unknown = set(spec) - allowed
        if unknown:
            raise SpaceError(
                f"{name}: unknown key(s) {sorted(unknown)}; allowed: {sorted(allowed)}"
            )
        if "fixed" in spec:
            extra = set(spec) - {"fixed", "unit", "doc"}
            if extra:
                raise SpaceError(f"{name}: 'fixed' cannot be combined with {sorted(extra)}")
            return cls(name, fixed=spec["fixed"], unit=spec.get("unit", ""), doc=spec.get("doc", ""))
        missing = [k for k in ("low", "high") if k not in spec]
        if missing:
            raise SpaceError(f"{name}: missing {missing}; a searched parameter needs low and high")
        for k in ("low", "high"):
            if isinstance(spec[k], bool) or not isinstance(spec[k], (int, float)):
                raise SpaceError(f"{name}.{k}: expected a number, got {spec[k]!r}")
        integer = spec.get("integer", False)
        if not isinstance(integer, bool):
            raise SpaceError(f"{name}.integer: expected true or false, got {integer!r}")
        return cls(
            name,
            low=spec["low"],
            high=spec["high"],
            scale=spec.get("scale", "linear"),
            integer=integer,
            unit=spec.get("unit", ""),
            doc=spec.get("doc", ""),
        )


def _plain(v: Any) -> Any:
    """numpy scalars/arrays -> Python builtins (for YAML/JSON)."""
    if isinstance(v, np.generic):
        return v.item()
    if isinstance(v, np.ndarray):
        return v.tolist()
    return v


class Space:
    """An ordered set of :class:`Real` parameters with the unit-cube encoding.

    ``encode``/``decode`` map between a dict of physical values and a vector of the ``dim`` free
    parameters in ``[0, 1]``; both work on single points and on ``(n, dim)`` batches.
    """

    def __init__(self, params: Iterable[Real]):
        self.params: tuple[Real, ...] = tuple(params)
        names = [p.name for p in self.params]
        dup = sorted({n for n in names if names.count(n) > 1})
        if dup:
            raise SpaceError(f"duplicate parameter name(s): {dup}")
        self.free: tuple[Real, ...] = tuple(p for p in self.params if not p.is_fixed)
        self.fixed: dict[str, Any] = {p.name: p.fixed for p in self.params if p.is_fixed}

    # --- construction -------------------------------------------------------------------------
    @classmethod
    def from_dict(cls, spec: Mapping[str, Any]) -> Space:
        return cls(Real.from_dict(name, s) for name, s in spec.items())

    def to_dict(self) -> dict[str, Any]:
        return {p.name: p.to_dict() for p in self.params}

    # --- shape --------------------------------------------------------------------------------
    @property
    def dim(self) -> int:
        return len(self.free)

    @property
    def names(self) -> list[str]:
        return [p.name for p in self.params]

    @property
    def free_names(self) -> list[str]:
        return [p.name for p in self.free]

    def __len__(self) -> int:
        return len(self.params)

    def __getitem__(self, name: str) -> Real:
        for p in self.params:
            if p.name == name:
                return p
        raise KeyError(name)

    def __contains__(self, name: object) -> bool:
        return any(p.name == name for p in self.params)

    def __repr__(self) -> str:
        return f"Space({list(self.params)!r})"

    def __eq__(self, other: object) -> bool:
        return isinstance(other, Space) and self.params == other.params

    # --- encoding -----------------------------------------------------------------------------
    def decode(self, u: Sequence[float] | np.ndarray) -> dict[str, Any]:
        """Unit-cube point (dim,) -> dict of every parameter's physical value (fixed included)."""
        u = np.asarray(u, dtype=float)
        if u.shape != (self.dim,):
            raise SpaceError(f"expected a point of shape ({self.dim},), got {u.shape}")
        out: dict[str, Any] = {}
        it = iter(u)
        for p in self.params:
            out[p.name] = p.fixed if p.is_fixed else p.from_unit(next(it))
        return out

    def decode_batch(self, u: np.ndarray) -> list[dict[str, Any]]:
        u = np.atleast_2d(np.asarray(u, dtype=float))
        return [self.decode(row) for row in u]

    def encode(self, values: Mapping[str, Any]) -> np.ndarray:
        """Dict of physical values -> unit-cube point (dim,). Fixed parameters may be omitted."""
        missing = [p.name for p in self.free if p.name not in values]
        if missing:
            raise SpaceError(f"missing value(s) for {missing}")
        unknown = sorted(set(values) - set(self.names))
        if unknown:
            raise SpaceError(f"unknown parameter(s) {unknown}; known: {self.names}")
        return np.array([p.to_unit(values[p.name]) for p in self.free], dtype=float)

    def validate(self, values: Mapping[str, Any]) -> None:
        """Raise :class:`SpaceError` naming the first value outside its declaration."""
        for p in self.params:
            if p.name not in values:
                if p.is_fixed:
                    continue
                raise SpaceError(f"missing value for {p.name!r}")
            if not p.contains(values[p.name]):
                allowed = repr(p.fixed) if p.is_fixed else f"[{p.low}, {p.high}]"
                raise SpaceError(f"{p.name}={values[p.name]!r} is outside {allowed}")

    def sample(self, rng: np.random.Generator, n: int) -> np.ndarray:
        """``n`` uniform points of the unit cube, shape (n, dim)."""
        return rng.random((n, self.dim))

    def narrowed(self, center: Mapping[str, Any], shrink: float) -> Space:
        """A space around ``center`` whose free ranges are ``shrink`` times the old ones.

        Widths are taken in the encoded (linear or log) coordinate; the new box is shifted to stay
        inside the old bounds. Used by two-stage refinement.
        """
        if not 0 < shrink <= 1:
            raise SpaceError(f"shrink must be in (0, 1], got {shrink}")
        new = []
        for p in self.params:
            if p.is_fixed:
                new.append(p)
                continue
            c = p.to_unit(center[p.name])
            lo_u = min(max(0.0, c - shrink / 2), 1.0 - shrink)
            hi_u = lo_u + shrink
            lo, hi = _unit_to_raw(p, lo_u), _unit_to_raw(p, hi_u)
            if p.integer and math.floor(hi) < math.ceil(lo):
                lo, hi = p.low, p.high
            if not lo < hi:
                lo, hi = p.low, p.high
            new.append(Real(p.name, lo, hi, p.scale, p.integer, unit=p.unit, doc=p.doc))
        return Space(new)


def _unit_to_raw(p: Real, u: float) -> float:
    if p.scale == "log":
        lo, hi = math.log10(p.low), math.log10(p.high)
        return 10.0 ** (lo + u * (hi - lo))
    return p.low + u * (p.high - p.low)
