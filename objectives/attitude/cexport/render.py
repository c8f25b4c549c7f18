"""The renderer: a filter's C port (:class:`~objectives.attitude.cexport.port.CPort`) with its values baked in.

It knows the shared parts (``templates/``) and the port contract, and no filter: everything specific to a
filter comes from the port its class declares (see :mod:`objectives.attitude.cexport`).
"""

from __future__ import annotations

import math
import re
from importlib import resources
from typing import Any

import numpy as np

from objectives.attitude.cexport.port import CField, CMember, CPort, RenderContext, c_literal, choice_enum, decl_fields
from objectives.attitude.filters.base import own
from objectives.attitude.filters.layout import Layout
from objectives.csource import c_identifier

__all__ = ["render_c_filter", "c_identifier", "c_port", "c_filter_names", "params_fields", "layout_enum"]

#: the start orientation of ``PFX_params.init`` (``init`` of :func:`render_c_filter`)
_INIT = {"accmag": 0, "broad": 1, "given": 2}
_FLOAT_LIT = re.compile(r"(?<![\w.])(\d+\.\d*(?:[eE][-+]?\d+)?|\d+[eE][-+]?\d+|\.\d+(?:[eE][-+]?\d+)?)(?![\w.])")
#: the streaming functions' definitions in the ports, made static (run.c defines the exported names)
_API_DEF = re.compile(r"^void PFX_(init|update|quaternion|set_quaternion)\(", re.MULTILINE)


def c_filter_names() -> list[str]:
    """The registered filters whose class declares a C port, sorted."""
    from objectives.attitude.filters.registry import filter_names, get_filter

    return [n for n in filter_names() if own(get_filter(n), "c_port") is not None]


def c_port(flt: Any) -> CPort:
    """The C port the class of ``flt`` declares; ValueError (listing the filters that have one) for none."""
    port = own(type(flt), "c_port")
    if port is None:
        raise ValueError(f"c-filter: no C port of filter {flt.name!r}; available: {c_filter_names()}")
    return port


def _shared(name: str) -> str:
    return resources.files(__package__).joinpath("templates", name).read_text()


def _source(port: CPort) -> str:
    package, name = port.source
    return resources.files(package).joinpath(name).read_text()


def params_fields(flt: Any, port: CPort, ctx: RenderContext, init: str, q0: Any) -> list[CField]:
    """The ``PFX_params`` members with their values: the sample time, the declaration's parameters
    (:func:`~objectives.attitude.cexport.port.decl_fields`), the port's own fields, the start orientation."""
    values = port.param_values(flt)
    q0 = [1.0, 0.0, 0.0, 0.0] if q0 is None else [float(x) for x in q0]
    return [CField("real", "dt_s", ctx.dt_s, "nominal sample time, s (coefficients are remade when dt_s changes)"),
            *decl_fields(port.declaration(flt), values, port.skip),
            *(port.fields(values, ctx) if port.fields is not None else []),
            CField("int", "init", _INIT[init], "start orientation: 0 first acc/mag sample, 1 BROAD's quatFromAccMag, "
                                               "2 q0"),
            CField("real", "q0[4]", q0, "start quaternion for init 2 (working frame)")]


def _choice_enums(flt: Any, port: CPort) -> list[str]:
    """``enum { PFX_NAME_CHOICE = i, ... };`` of every choice parameter in ``PFX_params``."""
    out = []
    for p in port.declaration(flt).params:
        if p.choices and not isinstance(p.default, bool) and p.name not in ("init", *port.skip):
            items = ", ".join(f"PFX_{n} = {i}" for n, i in choice_enum(p.name, p.choices))
            out.append(f"enum {{ {items} }}; /* {p.name} */")
    return out


def layout_enum(layout: Layout) -> str:
    """``enum { P_NAME = offset, ..., P_LEN = length };`` of a kernel layout (prefix ``P``)."""
    items = [f"{layout.prefix}_{f.name} = {f.offset}" for f in layout.fields] + [f"{layout.prefix}_LEN = {layout.LEN}"]
    lines, line = [], "   "
    for item in items:
        if len(line) + len(item) + 2 > 116:
            lines.append(line.rstrip())
            line = "   "
        line += f" {item},"
    lines.append(line.rstrip(","))
    return "enum {\n" + "\n".join(lines) + "\n};"


def _member(m: CMember) -> str:
    ctype = {"real": "PFX_real", "int": "int", "params": "PFX_params"}[m.ctype]
    dims = "".join(f"[{int(d)}]" for d in m.dims)
    decl = f"{ctype} {m.name}{dims};"
    return f"{decl:<17} /* {m.doc} */" if m.doc else decl


def _quat_literal(q: np.ndarray) -> str:
    return "{" + ", ".join(c_literal(float(c), "real") for c in q) + "}"


def render_c_filter(flt: Any, *, rate_hz: float, g: float = 9.80665, init: str = "accmag", q0=None,
                    precision: str = "double", prefix: str = "ATT", frame: str = "ENU",
                    comment: str = "") -> dict[str, str]:
    """Header and source of ``flt``'s C port with its values baked into ``PREFIX_tuned``.

    Parameters
    ----------
    flt : AttitudeFilter
        A validated filter whose class declares a ``c_port`` (its ``values`` are the complete configuration).
    rate_hz : float
        Sample rate the values assume, Hz (``dt_s = 1 / rate_hz``; coefficients follow a changed ``dt``).
    g : float
        Gravity in the accelerometer's unit (ports that compare ``|acc|`` with it, and rest detection).
    init : {"accmag", "broad", "given"}
        Start orientation: first sample, BROAD's quatFromAccMag, or ``q0`` (working frame).
    precision : {"double", "float"}
    prefix : str
        Prefix of every public C identifier; the files are ``<prefix lower>.h`` and ``.c``.
    frame : {"ENU", "NED", "NWU"}
        Earth frame of ``PREFIX_quaternion`` (and of ``PREFIX_set_quaternion``).
    comment : str
        Text for the header's leading comment (units, rate, provenance).

    Returns
    -------
    dict
        ``{filename: text}`` for the header and the source.
    """
    from objectives.attitude.quaternion.conversions import frame_rotation, qconj_batch

    port = c_port(flt)
    if precision not in ("double", "float"):
        raise ValueError(f"c-filter: precision must be 'double' or 'float', got {precision!r}")
    if init not in _INIT:
        raise ValueError(f"c-filter: init must be one of {sorted(_INIT)}, got {init!r}")
    if not (math.isfinite(rate_hz) and rate_hz > 0):
        raise ValueError(f"c-filter: rate_hz must be a finite number > 0, got {rate_hz!r}")
    pfx = c_identifier(prefix)
    base = pfx.lower()
    ctx = RenderContext(float(rate_hz), 1.0 / rate_hz, float(g), frame.upper(), precision)
    fields = params_fields(flt, port, ctx, init, q0)
    work = flt.working_frame
    # a tilt port's quaternion is a rotation about y in the frame it is defined in (``frame``)
    rot = np.array([1.0, 0.0, 0.0, 0.0]) if port.tilt else frame_rotation(work, frame.upper())

    params = "\n".join(f"    {'PFX_real' if f.ctype == 'real' else 'int'} {f.name}; /* {f.doc} */" for f in fields)
    state = "\n".join("    " + _member(m) for m in port.members(flt))
    enums = _choice_enums(flt, port)
    enums = ["", "/* the values of the configuration's choices (the params' int members of the same name) */",
             *enums] if enums else []
    header = _shared("header.h").replace("@ENUMS@\n", "".join(e + "\n" for e in enums))
    header = header.replace("@PARAMS@", params).replace("@STATE@", state)
    header = header.replace("@REAL@", precision).replace("@FRAME@", frame.upper())
    comment = comment.replace("/*", "/ *").replace("*/", "* /")  # nothing in it may end the comment
    header = "/*\n" + "\n".join((" * " + line).rstrip() for line in comment.splitlines()) + "\n */\n" + header

    init_vals = ",\n".join(f"    {c_literal(f.value, f.ctype)} /* {f.name.split('[')[0]} */" for f in fields)
    fl = precision == "float"
    pre = [f"/* {flt.name} filter, {precision} precision; see {base}.h. Generated: edit the tuning, not this file. */",
           "#include <math.h>", f'#include "{base}.h"', "",
           "typedef PFX_real real;",
           f"#define SQRT {'sqrtf' if fl else 'sqrt'}",
           f"#define EXP {'expf' if fl else 'exp'}",
           f"#define ASIN {'asinf' if fl else 'asin'}",
           f"#define ATAN2 {'atan2f' if fl else 'atan2'}",
           f"#define SIN {'sinf' if fl else 'sin'}",
           f"#define COS {'cosf' if fl else 'cos'}",
           "#define ISNAN_(x) isnan(x)",
           f"#define WORK_FRAME {({'ENU': 0, 'NED': 1}).get(work, 2)} /* {work} */",
           f"#define NWU_TO_WORK {_quat_literal(frame_rotation('NWU', work))}",
           f"#define WORK_TO_OUT {_quat_literal(rot)}",
           f"#define OUT_TO_WORK {_quat_literal(qconj_batch(rot))}",
           *(port.defines(flt, ctx) if port.defines is not None else []), ""]
    # the layouts' enums first: a shared part may read the port's state layout (node.c)
    body = _API_DEF.sub(r"static void PFX_\1_(", "\n".join([_shared("common.c"),
                                                            *(layout_enum(lay) for lay in port.layouts),
                                                            *(_shared(p) for p in port.parts), _source(port)]))
    body += "\n" + _shared("run.c")  # the exported names of the static functions and PFX_run
    tuned = f"const PFX_params PFX_tuned = {{\n{init_vals}\n}};\n"
    source = "\n".join(pre) + "\n" + tuned + "\n" + body
    if fl:
        source = _FLOAT_LIT.sub(lambda m: m.group(1) + "f", source).replace("fabs(", "fabsf(")
    return {f"{base}.h": header.replace("PFX_", pfx + "_"), f"{base}.c": source.replace("PFX_", pfx + "_")}
