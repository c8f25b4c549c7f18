"""What a filter unit declares for its C port, and the parts of the C every port shares.

A unit with a C port sets ``c_port = CPort(...)`` on its class (beside its kernel, in the unit's package);
:func:`objectives.attitude.cexport.render_c_filter` renders any class that has one, and never names a filter:

- ``PFX_params`` (the configuration struct, ``PFX_tuned`` its tuned values) is generated from the class's
  declaration (:func:`decl_fields`: a number is a ``real``, a bool or an integer option an ``int``, a choice
  an ``int`` indexing its choices, with an enum ``PFX_<NAME>_<CHOICE>`` in the header), less the port's
  ``skip``, plus the ``fields`` the port derives (values the C needs that the declaration does not hold,
  e.g. gravity in the accelerometer's unit);
- ``PFX_filter`` (the state struct) is the port's ``state``: :class:`CMember` entries whose sizes the unit
  takes from its kernel's layouts (:class:`objectives.attitude.filters.layout.Layout`);
- the C enums of the layouts the port lists (``enum { C_DT = 0, ..., C_LEN = 45 }``) come before its source,
  so the port indexes its arrays by the kernel's names;
- the source is ``common.c``, the shared ``parts`` the port lists (``cexport/templates/``), the port's own
  ``source`` (a file of the unit's package) and ``run.c``.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

from objectives.attitude.filters.layout import Layout
from objectives.attitude.filters.robust import ACC_STATE, MAG_COEF, MAG_STATE, REST_COEF, REST_STATE
from objectives.csource import CField, c_array, c_literal, choice_enum, decl_fields

__all__ = ["CField", "CMember", "CPort", "RenderContext", "decl_fields", "choice_enum", "c_literal", "c_array",
           "ROBUST_MEMBERS", "SHARED_PARTS"]

#: the shared parts a port may list in ``parts`` (files of ``cexport/templates/``), in the order they are
#: concatenated: a piece two ports need is written once, in the first part both get
SHARED_PARTS = ("robust.c", "bias_prologue.c", "trig.c", "angle.c", "node.c")


@dataclass(frozen=True)
class CMember:
    """One member of the ``PFX_filter`` struct: C type (``real``, ``int`` or ``params``), name, array
    dimensions (from the kernel's layouts), doc."""

    ctype: str
    name: str
    dims: tuple[int, ...] = ()
    doc: str = ""


@dataclass(frozen=True)
class RenderContext:
    """What a port's ``fields`` and ``defines`` may read besides the filter's values: the rate the values
    assume (Hz) and its sample time (s), gravity in the accelerometer's unit, the output frame, the precision."""

    rate_hz: float
    dt_s: float
    g: float
    frame: str
    precision: str


@dataclass(frozen=True)
class CPort:
    """A filter class's C port (module docstring).

    source : ``(package, file)``: the port's C, a resource of the unit's package (``(__package__, "port.c")``);
        it defines ``PFX_init``, ``PFX_update``, ``PFX_quaternion``, ``PFX_set_quaternion`` and
        ``PFX_gyro_bias`` (the header's API), the shared parts their helpers.
    parts : the shared parts it needs between ``common.c`` and ``source`` (names of :data:`SHARED_PARTS`).
    state : the members of ``PFX_filter`` (a function of the filter when they depend on its values).
    layouts : the kernel layouts rendered as C enums before ``source``.
    decl : the declaration ``PFX_params`` is made of (None: the class's ``decl``); a family whose classes share
        one port declares the family's complete one, ``values`` filling what a class does not have.
    values : ``values(flt) -> dict`` of ``decl``'s parameters (None: ``flt.values``); ValueError for a
        configuration the port cannot run.
    skip : parameters of ``decl`` that are not members of ``PFX_params`` (``init`` never is: the start is the
        render's ``init`` and ``q0``).
    fields : ``fields(values, ctx) -> [CField]``: members beyond ``decl`` (values the C derives nothing from).
    defines : ``defines(flt, ctx) -> [str]``: ``#define`` lines before the source (static tables).
    tilt : the output is the tilt about the sensor y axis as a quaternion in the export's frame (the 1-D
        filters): the frame is that of the recordings, and no frame rotation applies.
    gravity : the C compares ``|acc|`` with ``g`` = 9.80665 (the accelerometer in m/s^2), as the kernel does with
        g in the recording's unit; a check of the C on recordings in another unit rescales them.
    """

    source: tuple[str, str]
    parts: tuple[str, ...] = ()
    state: Sequence[CMember] | Callable[[Any], Sequence[CMember]] = ()
    layouts: tuple[Layout, ...] = ()
    decl: Any = None
    values: Callable[[Any], dict] | None = None
    skip: tuple[str, ...] = ()
    fields: Callable[[dict, RenderContext], list[CField]] | None = None
    defines: Callable[[Any, RenderContext], list[str]] | None = None
    tilt: bool = False
    gravity: bool = False
    doc: str = field(default="", compare=False)

    def __post_init__(self) -> None:
        unknown = [p for p in self.parts if p not in SHARED_PARTS]
        if unknown:
            raise ValueError(f"c port {self.source[1]}: unknown shared part(s) {unknown}; known: {SHARED_PARTS}")
        order = [SHARED_PARTS.index(p) for p in self.parts]
        if order != sorted(order):
            raise ValueError(f"c port {self.source[1]}: list the shared parts in the order {SHARED_PARTS}")

    def members(self, flt: Any) -> tuple[CMember, ...]:
        """The ``PFX_filter`` members for the filter ``flt``."""
        return tuple(self.state(flt) if callable(self.state) else self.state)

    def param_values(self, flt: Any) -> dict:
        """The values of the port's declaration for the filter ``flt``."""
        return dict(self.values(flt) if self.values is not None else flt.values)

    def declaration(self, flt: Any) -> Any:
        """The declaration ``PFX_params`` is made of."""
        return self.decl if self.decl is not None else type(flt).decl


#: the members ``robust.c`` reads and writes (the robust blocks' coefficients and states, the sample time the
#: coefficients were made for, the start flag, the params), sized by :mod:`objectives.attitude.filters.robust`
ROBUST_MEMBERS = (
    CMember("real", "mc", (MAG_COEF,), "magnetic rejection: coefficients and state"),
    CMember("real", "ms", (MAG_STATE,)),
    CMember("real", "rc", (REST_COEF,), "rest detection and rest bias: coefficients and state"),
    CMember("real", "rs", (REST_STATE,)),
    CMember("real", "alp_k", (), "earth-frame acc low-pass: gain and state"),
    CMember("real", "as", (ACC_STATE,)),
    CMember("real", "dt_s", (), "sample time the coefficients were made for, s"),
    CMember("int", "started", (), "0: start orientation from the next sample"),
    CMember("params", "p"),
)
