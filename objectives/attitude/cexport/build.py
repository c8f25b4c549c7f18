"""Compile rendered C filters with the local compiler and run them from Python through ctypes.

:func:`compile_shared` builds ``{filename: text}`` (from :func:`~objectives.attitude.cexport.render_c_filter`)
into a shared library in a directory of the caller's; :class:`CFilter` runs its ``PREFIX_run`` on whole
recordings. Used by ``tuner verify-c``, the tests and the filters benchmark.
"""

from __future__ import annotations

import ctypes
import os
import shutil
import subprocess
from pathlib import Path

import numpy as np

__all__ = ["find_compiler", "compile_shared", "CFilter", "STRICT_FLAGS", "CompileError"]

#: the warning flags every generated file must pass
STRICT_FLAGS = ("-std=c99", "-Wall", "-Wextra", "-Werror", "-pedantic")


class CompileError(RuntimeError):
    """The compiler rejected the source (its output is the message)."""


def find_compiler() -> str | None:
    """The C compiler: ``$CC`` if set and found, else ``cc``, ``gcc`` or ``clang`` on the PATH; None if none."""
    env = os.environ.get("CC")
    for name in ([env] if env else []) + ["cc", "gcc", "clang"]:
        path = shutil.which(name)
        if path:
            return path
    return None


def compile_shared(files: dict[str, str], out_dir: str | Path, opt: tuple[str, ...] = ("-O2",),
                   compiler: str | None = None) -> Path:
    """Write ``files`` into ``out_dir`` and link the ``.c`` among them into ``lib<stem>.so``.

    Raises :class:`CompileError` with the compiler's output when it fails, ``FileNotFoundError`` when there
    is no compiler.
    """
    cc = compiler or find_compiler()
    if cc is None:
        raise FileNotFoundError("no C compiler found (set CC or install cc/gcc/clang)")
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    for name, text in files.items():
        (out_dir / name).write_text(text)
    src = [out_dir / n for n in files if n.endswith(".c")]
    lib = out_dir / f"lib{src[0].stem}.so"
    cmd = [cc, *STRICT_FLAGS, *opt, "-fPIC", "-shared", "-o", str(lib), *map(str, src), "-lm"]
    res = subprocess.run(cmd, capture_output=True, text=True)
    if res.returncode != 0 or res.stderr.strip():
        raise CompileError(f"{' '.join(cmd)}\n{res.stderr}")
    return lib


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
