"""What the 1-D tilt filters share (thesis section 3.1; :mod:`objectives.attitude.filters.kf1d`): the angle
convention (the tilt about the sensor y axis in the recording's frame), the kernels' inputs, the start state of
the sample-code filters and the per-sample stream over the (previous, current) pair."""

from __future__ import annotations

import math

import numpy as np

from objectives.attitude.data.recording import Recording
from objectives.attitude.filters.kf1d.kernel import T, quat_from_tilt_kernel, tilt_state
from objectives.attitude.filters.stream import StateStream

__all__ = ["up_sign", "tilt_from_quat", "quat_from_tilt", "tilt_inputs", "tilt_start", "TiltStream"]


def up_sign(frame: str) -> float:
    """+1 in a z-up earth frame (ENU), -1 in NED: the sign of the specific force of gravity along up."""
    return -1.0 if frame.upper() == "NED" else 1.0


def tilt_from_quat(q: np.ndarray, frame: str, q_frame: str = "ENU") -> float:
    """Tilt angle about the sensor y axis (in ``frame``'s convention) of a quaternion in ``q_frame``.

    Uses only the sensor's up vector, so the heading of ``q`` does not matter.
    """
    from objectives.attitude.quaternion import to_frame

    w, x, y, z = to_frame(np.asarray(q, float), q_frame, "ENU")
    ux = 2.0 * (x * z - w * y)       # third row of R(q): earth up in the sensor frame
    uz = w * w - x * x - y * y + z * z
    s = up_sign(frame)
    return math.atan2(-s * ux, s * uz)


def quat_from_tilt(theta: np.ndarray) -> np.ndarray:
    """(N, 4) rotations about y by ``theta`` (N,) rad: ``(cos(theta/2), 0, sin(theta/2), 0)``."""
    theta = np.ascontiguousarray(np.asarray(theta, dtype=float).reshape(-1))
    q = np.empty((theta.shape[0], 4))
    quat_from_tilt_kernel(theta, q)
    return q


def tilt_inputs(rec: Recording) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The kernels' inputs: the rate about y (rad/s) and the specific force along x and z, (N,) each."""
    gy = np.ascontiguousarray(rec.gyr[:, 1], dtype=np.float64)
    ax = np.ascontiguousarray(rec.acc[:, 0], dtype=np.float64)
    az = np.ascontiguousarray(rec.acc[:, 2], dtype=np.float64)
    return gy, ax, az


def tilt_start(q0: np.ndarray, frame: str, q_frame: str) -> np.ndarray:
    """The Mahony/Madgwick 1-D kernels' start state (3,): the half-angle quaternion ``(cos, sin)`` of the tilt
    of ``q0`` (in ``q_frame``) in ``frame``'s convention (:func:`tilt_from_quat`,
    :func:`~objectives.attitude.filters.kf1d.kernel.tilt_state`) and a zero integral."""
    state = np.empty(T.LEN)
    tilt_state(tilt_from_quat(q0, frame, q_frame), state)
    return state


class TiltStream(StateStream):
    """Per-sample 1-D filter: sample 0 is the initial angle, every later sample one kernel call on the
    (previous, current) pair (the filter's ``_pair_step``), as the batch kernels do at that sample. Output in the
    stream's frame."""

    def _init_state(self, q0: np.ndarray) -> np.ndarray:
        f = self.filter
        self.output_frame = self.frame  # the 1-D filters work in the recording's own frame
        self._up = up_sign(self.frame)
        self._pair = (np.zeros(2), np.zeros(2), np.zeros(2))
        self._th = np.empty(2)
        self._b = np.empty(2)
        self._one = np.ones(1)
        self._theta = tilt_from_quat(q0, self.frame, f.working_frame)
        setup = f.kernel_setup(self.dt, False, q0, self.frame)
        self._coef = setup.coef
        return setup.state

    def _step(self, state, gyr, acc, mag):
        f = self.filter
        gy, ax, az = self._pair
        gy[0], ax[0], az[0] = gy[1], ax[1], az[1]
        gy[1], ax[1], az[1] = gyr[0, 1], acc[0, 0], acc[0, 2]
        if self.n > 0:
            f._pair_step(state, gy, ax, az, self._up, self._coef, self._th, self._b)
            self._theta = self._th[1]
        return quat_from_tilt(np.array([self._theta]))[0]
