"""What the filters of a ROS node share (``imu_tools_madgwick``, ``valenti``): each starts itself from its first
sample as the node does. :class:`NodeFilter` is their class's run and stream; :class:`NodeStream` the O(1) stream:
the kernel on one sample at a time with its state carried, the start state ``None`` (the kernel's own start)
unless the stream or the filter's ``init`` names another start."""

from __future__ import annotations

from typing import Any

import numpy as np

from objectives.attitude.data.recording import Recording
from objectives.attitude.filters.base import G_SI, AttitudeFilter, FilterResult
from objectives.attitude.filters.stream import StateStream

__all__ = ["NodeFilter", "NodeStream"]


def _node_start(init: Any, q0: Any) -> bool:
    """Whether the run starts as the node does, from its first sample (``init`` auto or accmag and no ``q0``)."""
    want = q0 if init == "auto" else init
    return want is None or (isinstance(want, str) and want in ("auto", "accmag"))


class NodeFilter(AttitudeFilter):
    """A node's filter: ``kernel(gyr, acc, mag, coef, state, out, bias_out)`` in the frame ``working_frame``, its
    ``kernel_setup`` taking ``q0=None`` as "start from the first sample"; the diagnostic ``gyr_bias`` (N, 3), rad/s."""

    def stream(self, rate_hz: float | None = None, dt: float | None = None, q0: Any = None, frame: str = "ENU"):
        """O(1) per-sample filter (the kernel with its state carried; equal to :meth:`run` on the samples so far),
        started from its first sample as the node is."""
        return NodeStream(self, rate_hz, dt, q0, frame)

    def _run_detailed(self, rec: Recording, q0: Any = None) -> FilterResult:
        if not _node_start(self.values.get("init", "auto"), q0):
            return super()._run_detailed(rec, q0)
        from objectives.attitude.quaternion import to_frame

        res = self._run(rec, None)  # the node's start from the first sample
        if res.frame != rec.frame:
            return FilterResult(to_frame(res.quat, res.frame, rec.frame), rec.frame, res.diagnostics)
        return res

    def _run(self, rec: Recording, q0: np.ndarray | None) -> FilterResult:
        if self.values["use_mag"] and rec.mag is None:
            raise ValueError(f"{self.name}: recording {rec.name!r} has no magnetometer; set use_mag: false")
        use_mag = bool(self.values["use_mag"]) and rec.mag is not None
        unit = str(rec.units.get("acc", "m/s^2")).replace(" ", "").lower()
        setup = self.kernel_setup(rec.dt, use_mag, q0, rec.frame, 1.0 if unit == "g" else G_SI)
        n = rec.gyr.shape[0]
        out, bias = np.empty((n, 4)), np.empty((n, 3))
        mag = np.ascontiguousarray(rec.mag, dtype=np.float64) if use_mag else np.zeros((0, 3))
        type(self).kernel(np.ascontiguousarray(rec.gyr, dtype=np.float64),
                          np.ascontiguousarray(rec.acc, dtype=np.float64), mag, setup.coef, setup.state, out, bias)
        return FilterResult(out, self.working_frame, {"gyr_bias": bias})


class NodeStream(StateStream):
    """``stream()`` of a filter whose ``kernel_setup`` takes ``q0=None`` as "start from the first sample" and whose
    kernel is ``kernel(gyr, acc, mag, coef, state, out, bias_out)`` (``self.filter.kernel``)."""

    def _initial_q(self, acc: np.ndarray, mag: np.ndarray | None) -> np.ndarray | None:
        if _node_start(self.filter.values.get("init", "auto"), self.q0):
            return None  # the kernel's own start from this sample
        return super()._initial_q(acc, mag)

    def _step(self, state: np.ndarray, gyr: np.ndarray, acc: np.ndarray, mag: np.ndarray) -> np.ndarray:
        type(self.filter).kernel(gyr, acc, mag, self._coef, state, self._out, np.empty((0, 3)))
        return self._out[0]
