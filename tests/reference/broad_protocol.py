"""The BROAD example code's evaluation protocol, written out in plain NumPy for tests.

D. Laidig et al., BROAD - A Benchmark for Robust Inertial Orientation Estimation, Data 6(7):72,
2021; ``example_code/broad_utils.py`` of the dataset. Its ``quatFromAccMag`` builds the matrix
``R = [x y z]`` whose columns are the earth axes (x = (acc x -mag) x acc, z = acc) expressed in the
sensor frame and converts it with a sign-copying formula. The quaternion it returns is therefore
the earth-to-sensor rotation of a south-east-up frame, which the filters then use as their
sensor-to-earth start value: for a nearly level sensor it is a few degrees off in inclination and
far off in heading. The published numbers were made with this start value, so reproducing them
needs it exactly; :func:`objectives.attitude.filters.base.quat_from_acc_mag` is the geometrically
correct initialisation and is not used for that comparison.
"""

from __future__ import annotations

import numpy as np

#: rotation applied to the filters' NWU output to compare it with BROAD's ENU truth
Q_ENU_FROM_NWU = np.array([1 / np.sqrt(2), 0.0, 0.0, 1 / np.sqrt(2)])


def broad_quat_from_rotmat(R: np.ndarray) -> np.ndarray:
    w_sq = (1 + R[0, 0] + R[1, 1] + R[2, 2]) / 4
    x_sq = (1 + R[0, 0] - R[1, 1] - R[2, 2]) / 4
    y_sq = (1 - R[0, 0] + R[1, 1] - R[2, 2]) / 4
    z_sq = (1 - R[0, 0] - R[1, 1] + R[2, 2]) / 4
    return np.array([
        np.sqrt(max(w_sq, 0.0)),
        np.copysign(np.sqrt(max(x_sq, 0.0)), R[2, 1] - R[1, 2]),
        np.copysign(np.sqrt(max(y_sq, 0.0)), R[0, 2] - R[2, 0]),
        np.copysign(np.sqrt(max(z_sq, 0.0)), R[1, 0] - R[0, 1]),
    ])


def broad_quat_from_acc_mag(acc: np.ndarray, mag: np.ndarray) -> np.ndarray:
    """BROAD's ``quatFromAccMag`` (see the module docstring for what it returns)."""
    z = np.asarray(acc, float)
    x = np.cross(np.cross(z, -np.asarray(mag, float)), z)
    y = np.cross(z, x)
    R = np.column_stack([x / np.linalg.norm(x), y / np.linalg.norm(y), z / np.linalg.norm(z)])
    return broad_quat_from_rotmat(R)
