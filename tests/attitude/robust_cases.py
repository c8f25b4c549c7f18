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
