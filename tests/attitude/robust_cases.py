"""What the filter tests share: a digest of output arrays for the bit-for-bit checks and the recording at rest
the robust blocks' tests run on."""

from __future__ import annotations

import hashlib

import numpy as np

from objectives.attitude.data.recording import Recording


def digest(*arrays) -> str:
    """SHA-256 of ``arrays``' dtypes, shapes and bytes (C order): equal exactly when the outputs are."""
    h = hashlib.sha256()
    for a in arrays:
        a = np.ascontiguousarray(a)
        h.update(str(a.dtype).encode())
        h.update(repr(a.shape).encode())
        h.update(a.tobytes())
    return h.hexdigest()


def rest_recording(n, dt=0.01, seed=0, bias=(0.0, 0.0, 0.0), lin=None) -> Recording:
    """``n`` samples at rest (ENU, identity truth) with gyro ``bias`` (rad/s), noise and ``lin(t)`` (m/s^2)
    added to the accelerometer when given."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) * dt
    gyr = np.tile(np.asarray(bias, float), (n, 1)) + rng.normal(0, 0.005, (n, 3))
    acc = np.tile([0.0, 0.0, 9.81], (n, 1)) + rng.normal(0, 0.03, (n, 3))
    if lin is not None:
        acc += lin(t)
    mag = np.tile([0.0, 20.0, -40.0], (n, 1)) + rng.normal(0, 0.1, (n, 3))
    return Recording("rest", gyr, acc, mag, dt, np.tile([1.0, 0.0, 0.0, 0.0], (n, 1)), np.ones(n, bool), "ENU")


def digest_recordings() -> tuple[Recording, Recording]:
    """The two bench recordings the pinned digests were computed on: 30 s at 100 Hz with external acceleration
    and magnetic disturbances (seed 3), and 20 s at 200 Hz (seed 5)."""
    from objectives.attitude.data.bench6dof import bench6dof

    return (bench6dof(30.0, 100.0, 3, vibration=False, ext_acc_max_g=0.5, mag_pert_range=(0.1, 0.5)),
            bench6dof(20.0, 200.0, 5))


def degenerate_arrays(rec: Recording) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Copies of ``rec``'s gyro, accelerometer and magnetometer with a zero, NaN or infinite sample each
    (accelerometer at 100 and 200, magnetometer at 300 and 400, gyro at 500)."""
    g, a, m = rec.gyr.copy(), rec.acc.copy(), rec.mag.copy()
    a[100] = 0
    a[200, 1] = np.nan
    m[300] = 0
    m[400, 2] = np.inf
    g[500, 0] = np.nan
    return g, a, m
