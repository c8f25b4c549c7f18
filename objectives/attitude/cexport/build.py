"""Run compiled C filters from Python through ctypes: :class:`CFilter` runs a library's ``PREFIX_run`` on whole
recordings (the library built by :func:`objectives.cbuild.compile_shared` from
:func:`~objectives.attitude.cexport.render_c_filter`'s files). Used by ``tuner verify-c``, the tests and the
filters benchmark."""

from __future__ import annotations

import ctypes
from pathlib import Path

import numpy as np

from objectives.csource import STRICT_FLAGS, CompileError, compile_shared, find_compiler

__all__ = ["find_compiler", "compile_shared", "CFilter", "STRICT_FLAGS", "CompileError"]


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
