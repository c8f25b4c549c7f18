"""The C every domain's export generates: literals, a declaration's struct members, and the compiler.

A tuned system leaves the tool as C whose configuration struct is generated from its declaration
(:class:`objectives.params.ParamSet`): :func:`decl_fields` makes one :class:`CField` per parameter (a number a
``real``, a bool or an integer option an ``int``, a choice an ``int`` indexing its choices, named by
:func:`choice_enum`), :func:`c_literal` and :func:`c_array` write the values.

:func:`compile_shared` builds ``{filename: text}`` (a filter's C of :mod:`objectives.attitude.cexport`, a
controller's of :mod:`objectives.control.plants.cexport`) into a shared library in a directory of the
caller's, with :data:`STRICT_FLAGS`: the generated C must compile without a single warning. Used by
``tuner verify-c``, the tests and the benchmarks.
"""

from __future__ import annotations

import math
import os
import re
import shlex
import shutil
import subprocess
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from tuner.objective import ToolError

__all__ = ["CField", "c_identifier", "c_literal", "c_array", "choice_enum", "decl_fields", "find_compiler",
           "compile_shared", "STRICT_FLAGS", "CompileError"]


@dataclass(frozen=True)
class CField:
    """One member of the ``PFX_params`` struct: C type (``real`` or ``int``), name (``q0[4]`` for an array),
    value, doc."""

    ctype: str
    name: str
    value: Any
    doc: str



def c_literal(x: Any, ctype: str = "real") -> str:
    """``x`` as a C literal of ``ctype`` (``real``: a double literal, ``INFINITY`` for inf; a list: an
    initialiser ``{...}``); the renderer turns double literals into float ones for ``precision="float"``."""
    if isinstance(x, list):
        return "{" + ", ".join(c_literal(e, ctype) for e in x) + "}"
    if ctype == "int":
        return str(int(x))
    x = float(x)
    if math.isinf(x):
        return "INFINITY" if x > 0 else "-INFINITY"
    s = repr(x)
    return s if ("." in s or "e" in s) else s + ".0"


def c_array(a: Any, ctype: str = "real") -> str:
    """A nested C initialiser ``{{...}, ...}`` of an array of any dimension."""
    a = np.asarray(a)
    if a.ndim == 1:
        return "{" + ", ".join(c_literal(x, ctype) for x in a.tolist()) + "}"
    return "{" + ", ".join(c_array(x, ctype) for x in a) + "}"


def _doc(p: Any) -> str:
    unit = f", {p.unit}" if p.unit and p.unit != "1" else ""
    return f"{p.doc}{unit}".replace("*/", "* /")


def c_identifier(prefix: str) -> str:
    """``prefix`` as a C identifier prefix (letters, digits, underscores; not starting with a digit)."""
    p = re.sub(r"\W", "_", str(prefix))
    if not p or p[0].isdigit():
        raise ValueError(f"prefix must be a C identifier (letters, digits, _; no leading digit), got {prefix!r}")
    return p


def choice_enum(name: str, choices: Sequence[Any]) -> list[tuple[str, int]]:
    """``[(NAME_CHOICE, index)]`` of a choice parameter's values (C identifiers, upper case)."""
    return [(f"{name}_{str(c)}".upper().replace("-", "_").replace(" ", "_"), i) for i, c in enumerate(choices)]


def decl_fields(decl: Any, values: dict, skip: Sequence[str] = ()) -> list[CField]:
    """The ``PFX_params`` members of ``decl``'s parameters (less ``init`` and ``skip``), with ``values``.

    A bool is an ``int`` 0/1, an integer option an ``int``, a choice an ``int`` indexing ``choices`` (enum
    :func:`choice_enum` in the header), anything else a ``real`` in the declaration's unit.
    """
    out = []
    for p in decl.params:
        if p.name in ("init", *skip):
            continue
        v = values[p.name]
        if p.kind == "any" or v is None:
            raise ValueError(f"c-source: parameter {p.name!r} ({p.kind}, value {v!r}) has no C type; the port leaves "
                             "it out (skip) or derives what the C needs from it (fields)")
        if isinstance(p.default, bool):
            out.append(CField("int", p.name, bool(v), _doc(p)))
        elif p.choices:
            names = ", ".join(f"{i} {c}" for i, c in enumerate(p.choices))
            out.append(CField("int", p.name, p.choices.index(v), f"{_doc(p)} ({names})"))
        elif p.integer:
            out.append(CField("int", p.name, int(v), _doc(p)))
        else:
            x = float(v)
            if math.isnan(x):
                raise ValueError(f"c-source: {p.name} is NaN")
            out.append(CField("real", p.name, x, _doc(p)))
    return out


#: the warning flags every generated file must pass
STRICT_FLAGS = ("-std=c99", "-Wall", "-Wextra", "-Werror", "-pedantic")


class CompileError(ToolError):
    """The compiler is missing, rejected the source or failed (the message names it and says why)."""


def find_compiler() -> list[str] | None:
    """The C compiler's command line: ``$CC`` split as a shell (and make) splits it, flags kept
    (``CC="gcc -m32"``), its program looked up on the PATH; else ``cc``, ``gcc`` or ``clang``; None without any.
    A ``$CC`` that is set but empty is ignored as make does; one whose program is not found is a
    :class:`CompileError` naming it (never silently replaced by another compiler)."""
    env = os.environ.get("CC", "")
    try:
        words = shlex.split(env)
    except ValueError as exc:
        raise CompileError(f"CC={env!r}: cannot be split into a command line ({exc})") from None
    if words:
        path = shutil.which(words[0])
        if path is None:
            raise CompileError(f"CC={env!r}: the compiler {words[0]!r} is not found (not on PATH, or not executable)")
        return [path, *words[1:]]
    for name in ("cc", "gcc", "clang"):
        path = shutil.which(name)
        if path:
            return [path]
    return None


def compile_shared(files: dict[str, str], out_dir: str | Path, opt: tuple[str, ...] = ("-O2",),
                   compiler: str | Sequence[str] | None = None) -> Path:
    """Write ``files`` into ``out_dir`` and link the ``.c`` among them into ``lib<stem>.so``.

    ``compiler``: a program or a command line (default :func:`find_compiler`). Raises :class:`CompileError`
    naming the compiler when there is none, when it fails or when it writes anything to stderr.
    """
    cc = ([compiler] if isinstance(compiler, str) else list(compiler)) if compiler else find_compiler()
    if cc is None:
        raise CompileError("no C compiler found (set CC, or install cc, gcc or clang)")
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    for name, text in files.items():
        (out_dir / name).write_text(text)
    src = [out_dir / n for n in files if n.endswith(".c")]
    lib = out_dir / f"lib{src[0].stem}.so"
    # Compile and link apart: linking with -ffast-math (or -Ofast) adds gcc's crtfastmath.o, whose
    # constructor sets flush-to-zero/denormals-are-zero in the MXCSR of the process that loads the library
    # (here: Python itself, for every later computation). The optimisation flags belong to the compile step.
    objs = [s.with_suffix(".o") for s in src]
    for s, o in zip(src, objs):
        _run_compiler([*cc, *STRICT_FLAGS, *opt, "-fPIC", "-c", "-o", str(o), str(s)], len(cc))
    _run_compiler([*cc, "-shared", "-o", str(lib), *map(str, objs), "-lm"], len(cc))
    if not lib.is_file():
        raise CompileError(f"the C compiler {shlex.join(cc)} exited 0 but wrote no library {lib.name}")
    return lib


def _run_compiler(cmd: list[str], n_cc: int) -> None:
    """Run the compiler; :class:`CompileError` (one line: the compiler, its exit status, its first message)
    when it fails or warns (the generated C must compile without a warning)."""
    try:
        res = subprocess.run(cmd, capture_output=True, text=True, errors="replace")
    except OSError as exc:
        raise CompileError(f"the C compiler {shlex.join(cmd[:n_cc])} cannot be run: {exc.strerror or exc}") from None
    if res.returncode != 0 or res.stderr.strip():
        said = next((ln.strip() for ln in (res.stderr + res.stdout).splitlines() if ln.strip()), "no message")
        raise CompileError(f"the C compiler {shlex.join(cmd[:n_cc])} "
                           + (f"failed (exit status {res.returncode})" if res.returncode else "wrote to stderr")
                           + f": {said[:300]}")
