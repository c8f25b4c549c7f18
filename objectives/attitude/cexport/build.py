"""Compile rendered C filters with the local compiler and run them from Python through ctypes.

:func:`compile_shared` builds ``{filename: text}`` (from :func:`~objectives.attitude.cexport.render_c_filter`)
into a shared library in a directory of the caller's; :class:`CFilter` runs its ``PREFIX_run`` on whole
recordings. Used by ``tuner verify-c``, the tests and the filters benchmark.
"""

from __future__ import annotations

import ctypes
import os
import shlex
import shutil
import subprocess
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from tuner.objective import ToolError

__all__ = ["find_compiler", "compile_shared", "CFilter", "STRICT_FLAGS", "CompileError"]

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


class CFilter:
    """A compiled C filter: ``run(gyr, acc, mag, dt, q0=None) -> (N, 4)`` in the export's output frame."""

    def __init__(self, lib: str | Path, prefix: str, precision: str = "double"):
        self._lib = ctypes.CDLL(str(lib))
        self.dtype = np.float64 if precision == "double" else np.float32
        self._fn = getattr(self._lib, f"{prefix}_run")
        self._fn.restype = None
        self._tuned = ctypes.c_void_p.in_dll(self._lib, f"{prefix}_tuned")

    def _arr(self, a) -> np.ndarray:
        return np.ascontiguousarray(a, dtype=self.dtype)

    def run(self, gyr, acc, mag, dt: float, q0=None) -> np.ndarray:
        """The filter over a whole recording at a fixed ``dt`` (s); ``mag`` None: no magnetometer;
        ``q0`` (4,) a start quaternion in the output frame, None: the configured start."""
        gyr, acc = self._arr(gyr), self._arr(acc)
        n = gyr.shape[0]
        mag_a = self._arr(mag) if mag is not None else None
        q0_a = self._arr(q0) if q0 is not None else None
        out = np.empty((n, 4), dtype=self.dtype)
        ptr = ctypes.POINTER(ctypes.c_double if self.dtype == np.float64 else ctypes.c_float)
        real = ctypes.c_double if self.dtype == np.float64 else ctypes.c_float

        def p(a):
            return a.ctypes.data_as(ptr) if a is not None else None

        params = ctypes.cast(ctypes.addressof(self._tuned), ctypes.c_void_p)
        self._fn(params, ctypes.c_long(n), p(gyr), p(acc), p(mag_a), real(dt), p(q0_a), p(out))
        return out.astype(np.float64, copy=False)  # double: the buffer the C wrote, no copy
