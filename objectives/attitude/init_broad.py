"""BROAD's own start orientation (``quatFromAccMag`` of the dataset's example code).

D. Laidig, M. Caruso, A. Cereatti, T. Seel, BROAD - A Benchmark for Robust Inertial Orientation
Estimation, Data 6(7):72, 2021; ``example_code/broad_utils.py``. The published per-trial RMSE of the
Madgwick and Mahony baselines (``published_results.json``) were computed with this start value, so a
filter option ``init: broad`` needs exactly it to reproduce them.

What it computes
----------------
With ``a`` the first accelerometer and ``m`` the first magnetometer sample (sensor frame), BROAD
builds the matrix ``R = [x/|x|, y/|y|, z/|z|]`` with columns::

    z = a,    x = (a x -m) x a,    y = z x x

and converts ``R`` with the sign-copying formula ``w = sqrt(1 + R00 + R11 + R22) / 2``,
``x = sign(R21 - R12) sqrt(1 + R00 - R11 - R22) / 2`` and cyclically (negative radicands clipped to
0). The columns are earth axes expressed in sensor coordinates, so the quaternion is the
earth-to-sensor rotation of a south-east-up frame; BROAD nevertheless passes it to its filters as
their sensor-to-earth start value in their north-west-up working frame and rotates their output to
ENU with ``[1/sqrt(2), 0, 0, 1/sqrt(2)]``. For a level sensor the result is a few degrees off in
inclination and far off in heading: it is *not* a good initialisation (that is
:func:`objectives.attitude.filters.base.quat_from_acc_mag`), only BROAD's.

For a filter whose working frame is not NWU, :func:`broad_start` returns the same physical start
(the NWU quaternion converted to the filter's frame), so every filter starts where BROAD's would.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["broad_quat_from_acc_mag", "broad_start", "broad_initial_quaternion"]


def _sign_copy_quat(R: np.ndarray) -> np.ndarray:
    """BROAD's rotation-matrix-to-quaternion conversion (sign copying, no branch on the trace)."""
    rad = ((1 + R[0, 0] + R[1, 1] + R[2, 2]), (1 + R[0, 0] - R[1, 1] - R[2, 2]),
           (1 - R[0, 0] + R[1, 1] - R[2, 2]), (1 - R[0, 0] - R[1, 1] + R[2, 2]))
    mag = [0.5 * math.sqrt(max(r, 0.0)) for r in rad]
    return np.array([
        mag[0],
        math.copysign(mag[1], R[2, 1] - R[1, 2]),
        math.copysign(mag[2], R[0, 2] - R[2, 0]),
        math.copysign(mag[3], R[1, 0] - R[0, 1]),
    ])


def broad_quat_from_acc_mag(acc: np.ndarray, mag: np.ndarray) -> np.ndarray:
    """BROAD's ``quatFromAccMag`` of one sample: (4,) ``(w, x, y, z)``, read as NWU sensor-to-earth.

    Parameters
    ----------
    acc : (3,) array_like
        Accelerometer sample (any unit), sensor frame; must not be zero.
    mag : (3,) array_like
        Magnetometer sample (any unit), sensor frame; must not be parallel to ``acc``.

    Raises
    ------
    ValueError
        Non-finite or wrong-shaped input, zero ``acc``, or ``mag`` parallel to ``acc`` (no heading).
    """
    a = np.asarray(acc, dtype=float).reshape(-1)
    m = np.asarray(mag, dtype=float).reshape(-1)
    for name, v in (("acc", a), ("mag", m)):
        if v.shape != (3,) or not np.isfinite(v).all():
            raise ValueError(f"init broad: {name} must be 3 finite numbers, got {v.tolist()}")
    x = np.cross(np.cross(a, -m), a)
    y = np.cross(a, x)
    na, nx, ny = np.linalg.norm(a), np.linalg.norm(x), np.linalg.norm(y)
    if na == 0:
        raise ValueError("init broad: first accelerometer sample is zero; no inclination")
    if nx <= 1e-12 * na * na * max(np.linalg.norm(m), 1e-300):
        raise ValueError("init broad: first magnetometer sample is parallel to the accelerometer; no heading")
    R = np.column_stack([x / nx, y / ny, a / na])
    return _sign_copy_quat(R)


def broad_start(acc0: np.ndarray, mag0: np.ndarray, frame: str = "NWU") -> np.ndarray:
    """BROAD's start value as a sensor-to-earth quaternion (4,) in the earth frame ``frame``.

    ``frame`` is the filter's working frame (``"NWU"``, ``"ENU"`` or ``"NED"``); for NWU this is
    :func:`broad_quat_from_acc_mag` itself, for the others the same rotation expressed there. Pass it
    as ``q0`` to :meth:`AttitudeFilter.run <objectives.attitude.filters.base.AttitudeFilter.run>` of a
    filter working in ``frame``.
    """
    from objectives.attitude.quaternion import to_frame

    q = broad_quat_from_acc_mag(acc0, mag0)
    return to_frame(q, "NWU", frame)


def broad_initial_quaternion(rec, frame: str) -> np.ndarray:
    """:func:`broad_start` of a recording's first accelerometer and magnetometer sample, in ``frame``.

    The hook for a filter option ``init: broad`` (``q0 == "broad"`` in
    :func:`objectives.attitude.filters.base.initial_quaternion`).

    Raises
    ------
    ValueError
        The recording has no magnetometer (BROAD's start needs one), or its first samples are degenerate.
    """
    if rec.mag is None:
        raise ValueError(f"{rec.name}: init broad needs a magnetometer; the recording has none")
    return broad_start(rec.acc[0], rec.mag[0], frame)
