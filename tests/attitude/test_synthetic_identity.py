"""Synthetic recordings stay bit-identical across refactorings of the generators.

The digests below were computed from the generators before ``synthetic.py`` was split into the
IMU model, bench and cache modules (commit 4db42a0). Every array of the recording (gyr, acc, mag,
quat, motion, extra signals, with dtype and shape), ``dt`` and the metadata go into one SHA-256, so
any change in a random draw, an operation order or a rounding shows. The digests hold for the
pinned NumPy on x86-64: NumPy keeps the raw ``PCG64`` stream fixed (NEP 19) but may change a
``Generator`` distribution or its vectorised ``sin``/``arctan2`` between versions or CPUs; after such
an upgrade, recompute them from the commit that last passed, never from the code under test.
"""

from __future__ import annotations

import hashlib
import json

import numpy as np
import pytest

from objectives.attitude.data.synthetic import bench6dof, tilt1d


def _digest(rec) -> str:
    """SHA-256 of every array of ``rec`` (with dtype and shape), ``dt`` and its metadata."""
    h = hashlib.sha256()
    for name in ("gyr", "acc", "mag", "quat", "motion"):
        a = getattr(rec, name)
        h.update(name.encode())
        if a is not None:
            a = np.ascontiguousarray(a)
            h.update(str(a.dtype).encode())
            h.update(repr(a.shape).encode())
            h.update(a.tobytes())
    h.update(np.float64(rec.dt).tobytes())
    for k in sorted(rec.extra):
        a = np.ascontiguousarray(rec.extra[k])
        h.update(k.encode())
        h.update(str(a.dtype).encode())
        h.update(a.tobytes())
    h.update(json.dumps([rec.name, rec.frame, dict(rec.units), rec.source], sort_keys=True).encode())
    return h.hexdigest()


CASES = {
    "bench6dof_default_4s": (
        lambda: bench6dof(duration_s=4.0, rate_hz=200.0, seed=3),
        "a9a2d1c53b35d500087cd9ee7fdc44479e5d66e97d6796d50ca4f14d7f1849f4"),
    "bench6dof_long_enu": (
        lambda: bench6dof(duration_s=25.0, rate_hz=100.0, seed=7, frame="ENU", start_static_s=1.0),
        "4f2a1522c7b4ebbe9ba6c6da680b35c0d043224940b1c26be2ec801d0c1b8c2f"),
    "bench6dof_nonoise": (
        lambda: bench6dof(duration_s=12.0, rate_hz=100.0, seed=1, noise=False, ext_acc_max_g=16),
        "ec7733055b174167eb45c61f88dbd6e76ba475dd783db8a26b17a071aaeca652"),
    "tilt1d_default": (
        lambda: tilt1d(duration_s=20.0, rate_hz=200.0, seed=5),
        "3b2aaadc0848bbea901e0f8241609202dd402037b153b440eeb1c97740da72a2"),
    "tilt1d_mag_enu": (
        lambda: tilt1d(duration_s=15.0, rate_hz=100.0, seed=2, with_mag=True, frame="ENU"),
        "e3d1842bc3e988625055ac9184cd580f5dca1c3fe1b4fe549a2948e54d82c19d"),
}


@pytest.mark.parametrize("case", sorted(CASES))
def test_recording_bit_identical_to_recorded_digest(case):
    make, expected = CASES[case]
    assert _digest(make()) == expected


def test_digest_sees_a_one_ulp_change():
    rec = bench6dof(duration_s=2.0, rate_hz=100.0, seed=0)
    before = _digest(rec)
    rec.gyr[5, 1] = np.nextafter(rec.gyr[5, 1], np.inf)
    assert _digest(rec) != before
