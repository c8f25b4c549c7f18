"""The O(1) stream of a filter that starts itself from its first sample, as a ROS node does (``imu_tools_madgwick``,
``valenti``): the kernel on one sample at a time with its state carried, the start state ``None`` (the kernel's
own start) unless the stream or the filter's ``init`` names another start."""

from __future__ import annotations

import numpy as np

from objectives.attitude.filters.stream import StateStream

__all__ = ["NodeStream"]


class NodeStream(StateStream):
    """``stream()`` of a filter whose ``kernel_setup`` takes ``q0=None`` as "start from the first sample" and whose
    kernel is ``kernel(gyr, acc, mag, coef, state, out, bias_out)`` (``self.filter.kernel``)."""

    def _initial_q(self, acc: np.ndarray, mag: np.ndarray | None) -> np.ndarray | None:
        init = self.filter.values.get("init", "auto")
        want = self.q0 if init == "auto" else init
        if want is None or (isinstance(want, str) and want in ("auto", "accmag")):
            return None  # the kernel's own start from this sample
        return super()._initial_q(acc, mag)

    def _step(self, state: np.ndarray, gyr: np.ndarray, acc: np.ndarray, mag: np.ndarray) -> np.ndarray:
        type(self.filter).kernel(gyr, acc, mag, self._coef, state, self._out, np.empty((0, 3)))
        return self._out[0]
