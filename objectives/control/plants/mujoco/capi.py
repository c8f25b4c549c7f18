"""MuJoCo's C functions as the compiled loop calls them, and MuJoCo's warnings kept off the terminal.

The closed-loop kernel (:mod:`.kernel`) steps the physics itself, with no Python between two engine
steps: it calls ``mj_step1``, ``mj_step2``, ``mj_step`` and ``mj_differentiatePos`` of the shared library
the ``mujoco`` package ships (the same library its Python bindings use, so the ``mjModel`` and ``mjData``
the bindings made are the ones the kernel steps: their addresses are ``MjModel._address`` and
``MjData._address``). Numba calls a ``ctypes`` function passed as an argument directly, without the GIL,
so several threads step their own ``mjData`` at once.

Warnings. MuJoCo's default warning handler prints to the terminal and appends to ``MUJOCO_LOG.TXT`` in the
working directory; a tuning that tries an unstable candidate would do both. While a compiled loop runs,
:func:`quiet_warnings` points ``mju_user_warning`` at a handler that does nothing and puts the previous
handler back afterwards (counted, so nested and concurrent loops restore it once); the loop reads the
warning counters of its ``mjData`` instead (:func:`warnings_of`), and an evaluation that MuJoCo warned about
fails with MuJoCo's text. The handler is the process's: a simulation the caller runs on another thread at
the same time is not printed either (its ``mjData`` still counts its warnings).

Errors (``mju_error``) are not warnings: MuJoCo's default handler ends the process, so the plant's builder
runs one period through the Python bindings first (where an error is an exception, hence a config error),
and only a model that ran there reaches the compiled loop.
"""

from __future__ import annotations

import ctypes
import glob
import os
import threading
from contextlib import contextmanager
from dataclasses import dataclass
from functools import cache
from typing import Any

__all__ = ["CApi", "capi", "quiet_warnings", "warnings_of", "library_path"]

_PATTERNS = ("libmujoco.so*", "libmujoco*.dylib", "mujoco.dll")


def library_path() -> str:
    """The shared library of the installed ``mujoco`` package (``ValueError`` if it is not beside it)."""
    import mujoco

    here = os.path.dirname(mujoco.__file__)
    for pattern in _PATTERNS:
        found = sorted(glob.glob(os.path.join(here, pattern)))
        if found:
            return found[0]
    raise ValueError(f"MuJoCo's shared library is not in {here} (looked for {', '.join(_PATTERNS)})")


@dataclass(frozen=True)
class CApi:
    """The ``ctypes`` functions the kernel calls: ``step1``, ``step2``, ``step`` (``(m, d)``) and
    ``diffpos`` (``mj_differentiatePos(m, qvel, dt, qpos1, qpos2)``, pointers as integers)."""

    lib: Any
    step1: Any
    step2: Any
    step: Any
    diffpos: Any


@cache
def capi() -> CApi:
    """The library's functions, loaded once per process."""
    lib = ctypes.CDLL(library_path())
    vp = ctypes.c_void_p

    def fn(name: str, *args: Any) -> Any:
        f = getattr(lib, name)
        f.argtypes = list(args)
        f.restype = None
        return f

    return CApi(lib, fn("mj_step1", vp, vp), fn("mj_step2", vp, vp), fn("mj_step", vp, vp),
                fn("mj_differentiatePos", vp, vp, ctypes.c_double, vp, vp))


_lock = threading.Lock()
_depth: list[Any] = [0, None]  # loops inside quiet_warnings, the handler to put back


@cache
def _ignore_address() -> int:
    """The address of a compiled C function ``void f(const char*)`` that does nothing (no GIL taken)."""
    from numba import cfunc, types

    @cfunc(types.void(types.voidptr))
    def _ignore(_msg):  # pragma: no cover - compiled; only MuJoCo calls it
        return

    _KEEP.append(_ignore)
    return int(_ignore.address)


_KEEP: list[Any] = []  # the compiled handler lives as long as the process


@contextmanager
def quiet_warnings():
    """MuJoCo's warnings go nowhere while the block runs (module docstring); the previous handler after."""
    slot = ctypes.c_void_p.in_dll(capi().lib, "mju_user_warning")
    with _lock:
        if _depth[0] == 0:
            _depth[1] = slot.value
            slot.value = _ignore_address()
        _depth[0] += 1
    try:
        yield
    finally:
        with _lock:
            _depth[0] -= 1
            if _depth[0] == 0:
                slot.value = _depth[1]


def warnings_of(data: Any) -> str:
    """MuJoCo's text of the first warning ``data`` counted since its last reset ('' if none)."""
    import mujoco

    for i, w in enumerate(data.warning):
        if w.number > 0:
            return mujoco.mju_warningText(mujoco.mjtWarning(i), int(w.lastinfo))
    return ""
