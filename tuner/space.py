"""Parameter spaces: named parameters, their bounds and scales, and the unit-cube encoding.

Optimisers only ever see points of the unit cube ``[0, 1]^d`` where ``d`` is the number of free
parameters; :class:`Space` alone knows physical units, log scales, integers and fixed values.

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
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np

__all__ = ["Real", "Space", "SpaceError"]


class SpaceError(ValueError):
    """A parameter declaration or a value that does not fit its declaration."""


_MISSING = object()


@dataclass(frozen=True)
class Real:
    """One named parameter.

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

    name: str
    low: float = math.nan
    high: float = math.nan
    scale: Literal["linear", "log"] = "linear"
    integer: bool = False
    fixed: Any = field(default=_MISSING)
    unit: str = ""
    doc: str = ""

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not self.name.isidentifier():
            raise SpaceError(f"parameter name must be an identifier, got {self.name!r}")
        if self.is_fixed:
            return
        if self.scale not in ("linear", "log"):
            raise SpaceError(f"{self.name}: scale must be 'linear' or 'log', got {self.scale!r}")
        try:
            low, high = float(self.low), float(self.high)
        except (TypeError, ValueError):
            raise SpaceError(
                f"{self.name}: low and high must be numbers, got low={self.low!r}, high={self.high!r}"
            ) from None
        object.__setattr__(self, "low", low)
        object.__setattr__(self, "high", high)
        if not (math.isfinite(low) and math.isfinite(high) and low < high):
            raise SpaceError(f"{self.name}: need finite low < high, got low={low}, high={high}")
        if self.scale == "log" and low <= 0:
            raise SpaceError(f"{self.name}: log scale needs low > 0, got low={low}")
        if self.integer and math.floor(high) < math.ceil(low):
            raise SpaceError(f"{self.name}: integer parameter has no integer in [{low}, {high}]")

    @property
    def is_fixed(self) -> bool:
        return self.fixed is not _MISSING

    # --- scalar maps -------------------------------------------------------------------------
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
        if self.scale == "log":
            lo, hi = math.log10(self.low), math.log10(self.high)
            v = 10.0 ** (lo + u * (hi - lo))
        else:
            v = self.low + u * (self.high - self.low)
        v = min(self.high, max(self.low, v))
        if self.integer:
            return int(min(math.floor(self.high), max(math.ceil(self.low), round(v))))
        return v

    def contains(self, value: Any) -> bool:
        if self.is_fixed:
            return value == self.fixed
        try:
            v = float(value)
        except (TypeError, ValueError):
            return False
        return self.low <= v <= self.high and (not self.integer or float(v).is_integer())

    def to_dict(self) -> dict[str, Any]:
        """YAML-native form, the inverse of :meth:`from_dict`."""
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
