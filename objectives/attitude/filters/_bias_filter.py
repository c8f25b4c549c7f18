"""What Madgwick and Mahony share: a kernel ``kernel(gyr, acc, mag, coef, state, out, bias_out)`` whose
state is the quaternion and a gyro bias (``state`` (7,): q (4,), bias (3,)), called on whole arrays by
``run`` and on one sample at a time by ``stream``. Each filter supplies its kernel, the function that
builds its coefficient array, and the name of the parameter that switches the bias estimate on.
"""

from __future__ import annotations

from typing import Any, ClassVar

import numpy as np
from numba import njit

from objectives.attitude.data.recording import Recording
from objectives.attitude.filters._scalar import read_unit
from objectives.attitude.filters.base import AttitudeFilter, FilterResult
from objectives.attitude.filters.stream import StateStream
from objectives.params import POSITIVE, ParamSet, check_number, imu_arrays, unit_quaternion

__all__ = ["BiasKernelFilter", "run_bias_kernel", "batch_on_arrays", "io_flags", "read_mag"]


@njit(cache=True, inline="always")
def io_flags(use_mag_coef, gyr, mag, bias_out):
    """The kernels' ``(use_mag, write_bias)``: the magnetometer is used when its coefficient is not 0 and
    it has a row per gyro sample; the bias is written when ``bias_out`` has a row per sample."""
    n = gyr.shape[0]
    return use_mag_coef != 0.0 and mag.shape[0] == n, bias_out.shape[0] == n


@njit(cache=True, inline="always")
def read_mag(mag, i, use_mag):
    """The kernels' magnetometer sample ``i``: ``(x, y, z, ok)``, the unit field when ``use_mag`` and the
    row is usable (:func:`~objectives.attitude.filters._scalar.read_unit`), else ``(0, 0, 0, False)``."""
    if use_mag:
        return read_unit(mag, i)
    return 0.0, 0.0, 0.0, False


def run_bias_kernel(kernel: Any, coef: np.ndarray, gyr: np.ndarray, acc: np.ndarray, mag: np.ndarray,
                    q0: np.ndarray, with_bias: bool):
    """One kernel call on checked contiguous arrays: (N, 4) quaternions, and the (N, 3) bias if asked."""
    n = gyr.shape[0]
    state = np.zeros(7)
    state[:4] = q0
    out = np.empty((n, 4))
    bias = np.empty((n if with_bias else 0, 3))
    kernel(gyr, acc, mag, coef, state, out, bias)
    return (out, bias) if with_bias else out


def batch_on_arrays(decl: ParamSet, kernel: Any, coef: Any, values: dict, gyr, acc, mag, dt: float, q0,
                    with_bias: bool):
    """The ``*_batch`` functions: validate ``values`` against ``decl`` and the arrays, then one kernel call."""
    name = decl.owner
    v = decl.validate(values)
    gyr, acc, mag = imu_arrays(name, gyr, acc, mag)
    dt = check_number(name, "dt", dt, POSITIVE, "s")
    return run_bias_kernel(kernel, coef(v, dt, mag.shape[0] > 0), gyr, acc, mag, unit_quaternion(name, "q0", q0),
                           with_bias)


class BiasKernelFilter(AttitudeFilter):
    """Base of Madgwick and Mahony (NWU working frame, ``gyr_bias`` diagnostic when the bias is on).

    Subclasses name, as class keywords, their ``kernel``, ``coef`` (``coef(values, dt, has_mag) -> array``)
    and ``bias_param``, the parameter whose positive value turns the bias estimate on::

        class Madgwick(BiasKernelFilter, kernel=_madgwick_kernel, coef=_coef, bias_param="zeta"): ...
    """

    working_frame = "NWU"
    needs_mag = True
    kernel: ClassVar[Any]
    coef: ClassVar[Any]
    bias_param: ClassVar[str]

    def __init_subclass__(cls, kernel: Any = None, coef: Any = None, bias_param: str | None = None,
                          **kwargs: Any) -> None:
        if kernel is not None:
            cls.kernel = staticmethod(kernel)
            cls.coef = staticmethod(coef)
            cls.bias_param = bias_param
        super().__init_subclass__(**kwargs)

    def _run(self, rec: Recording, q0: np.ndarray) -> FilterResult:
        v = self.values
        gyr, acc, mag = imu_arrays(self.name, rec.gyr, rec.acc, rec.mag if v["use_mag"] else None)
        with_bias = v[self.bias_param] > 0
        res = run_bias_kernel(self.kernel, self.coef(v, rec.dt, mag.shape[0] > 0), gyr, acc, mag, q0, with_bias)
        if with_bias:
            return FilterResult(res[0], self.working_frame, {"gyr_bias": res[1]})
        return FilterResult(res, self.working_frame)

    def stream(self, rate_hz: float | None = None, dt: float | None = None, q0=None, frame: str = "ENU"):
        return _BiasKernelStream(self, rate_hz, dt, q0, frame)


class _BiasKernelStream(StateStream):
    """O(1) per-sample stream: the kernel on one sample with quaternion and bias carried in ``state``."""

    def _init_state(self, q0: np.ndarray) -> np.ndarray:
        flt = self.filter
        self._kernel = flt.kernel
        self._coefs = {m: flt.coef(flt.values, self.dt, m) for m in (False, True)}
        self._out = np.empty((1, 4))
        self._bias = np.empty((0, 3))
        state = np.zeros(7)
        state[:4] = q0
        return state

    def _step(self, state, gyr, acc, mag):
        self._kernel(gyr, acc, mag, self._coefs[mag.shape[0] > 0], state, self._out, self._bias)
        return self._out[0]
