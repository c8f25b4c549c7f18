"""Plausibility checks of recorded data: implausible units and a start in motion.

One check each, used wherever data enter: the CSV, BROAD and synthetic paths of the filter objective
(its preflight), the array API (``Filter.run(gyr, acc, mag, rate_hz=...)``) and ``Filter.stream()``.

Units (:func:`unit_warnings`)
    ``gyr`` declared rad/s whose 99th-percentile magnitude exceeds 35 rad/s (~2000 deg/s, the largest
    common MEMS range) is most likely deg/s; ``acc`` declared m/s^2 whose median magnitude lies in
    (0.5, 2.0) is most likely in g (at rest ``|acc|`` is 9.81 m/s^2).
Start in motion (:func:`motion_start`)
    An ``accmag``/``broad`` start takes the orientation from the first accelerometer (and magnetometer)
    sample, which is gravity only at rest. A recording is *in motion at its start* when, over its first
    :data:`START_WINDOW_S` seconds (at least :data:`START_MIN_SAMPLES` samples), the mean gyro norm
    exceeds :data:`START_GYR_RAD_S` or the mean of ``| |acc| - g |`` exceeds :data:`START_ACC_DEV`.
    Chosen from the 16 BROAD trials (286 Hz): at rest their 0.25 s windows have a gyro norm of at most
    0.016 rad/s (mean <= 0.011) and ``| |acc| - g |`` of at most 0.34 m/s^2, while every motion window
    of the slowest trials has a mean gyro norm >= 0.4 rad/s; the thresholds sit about 10x above the
    resting noise and 4x below the slowest motion.
"""

from __future__ import annotations

import math
import warnings

import numpy as np

__all__ = ["UnitWarning", "unit_warnings", "unit_messages", "warn_units", "motion_start", "START_WINDOW_S",
           "START_GYR_RAD_S", "START_ACC_DEV"]

#: |gyr| above this (rad/s, ~2000 deg/s, the largest common MEMS range) at the 99th percentile means deg/s
GYR_MAX_RAD_S = 35.0
#: median |acc| inside this band (m/s^2) means the data are in g, not m/s^2 (at rest |acc| is 9.81)
ACC_G_BAND = (0.5, 2.0)
#: seconds at the start of a recording over which "in motion" is decided
START_WINDOW_S = 0.25
#: at least this many samples in that window (low rates)
START_MIN_SAMPLES = 5
#: mean gyro norm (rad/s, ~5.7 deg/s) above which the start is in motion
START_GYR_RAD_S = 0.1
#: mean deviation of |acc| from standard gravity (m/s^2, ~0.1 g) above which the start is in motion
START_ACC_DEV = 1.0
_G = 9.80665


class UnitWarning(UserWarning):
    """Data whose magnitudes do not fit the units they are declared in (see :func:`unit_warnings`)."""


def unit_warnings(rec) -> list[str]:
    """Warnings when a recording's gyr/acc magnitudes do not fit their declared units (rad/s, m/s^2)."""
    units = dict(rec.units)
    return unit_messages(rec.name, rec.gyr, rec.acc, str(units.get("gyr", "rad/s")), str(units.get("acc", "m/s^2")))


def unit_messages(name: str, gyr: np.ndarray, acc: np.ndarray, gyr_unit: str = "rad/s",
                  acc_unit: str = "m/s^2") -> list[str]:
    """:func:`unit_warnings` on plain (N, 3) arrays (N >= 1) declared in ``gyr_unit`` and ``acc_unit``."""
    out = []
    g99 = float(np.percentile(np.linalg.norm(gyr, axis=1), 99))
    if gyr_unit == "rad/s" and g99 > GYR_MAX_RAD_S:
        out.append(f"{name}: gyr is declared rad/s but its 99th-percentile magnitude is {g99:.4g} "
                   f"(> {GYR_MAX_RAD_S:g} rad/s = {math.degrees(GYR_MAX_RAD_S):.0f} deg/s): is it in deg/s?")
    a50 = float(np.median(np.linalg.norm(acc, axis=1)))
    if acc_unit == "m/s^2" and ACC_G_BAND[0] < a50 < ACC_G_BAND[1]:
        out.append(f"{name}: acc is declared m/s^2 but its median magnitude is {a50:.4g} "
                   "(gravity is 9.81 m/s^2): is it in g?")
    return out


def warn_units(name: str, gyr: np.ndarray, acc: np.ndarray, stacklevel: int = 3) -> bool:
    """One :class:`UnitWarning` with every message of :func:`unit_messages` for arrays in rad/s and m/s^2
    (none if plausible). Returns whether it warned."""
    msgs = unit_messages(name, gyr, acc)
    if msgs:
        warnings.warn("; ".join(msgs) + " (the array API takes gyr in rad/s and acc in m/s^2)", UnitWarning,
                      stacklevel=stacklevel)
    return bool(msgs)


def motion_start(rec) -> str:
    """Why ``rec`` is in motion at its start (empty when it starts at rest); see the module docstring."""
    n = min(rec.n, max(START_MIN_SAMPLES, int(round(START_WINDOW_S / rec.dt))))
    gyr = float(np.mean(np.linalg.norm(rec.gyr[:n], axis=1)))
    acc = float(np.mean(np.abs(np.linalg.norm(rec.acc[:n], axis=1) - _G)))
    why = []
    if gyr > START_GYR_RAD_S:
        why.append(f"mean gyro norm {gyr:.3g} rad/s > {START_GYR_RAD_S:g}")
    if acc > START_ACC_DEV:
        why.append(f"mean | |acc| - g | {acc:.3g} m/s^2 > {START_ACC_DEV:g}")
    return f"over its first {n * rec.dt:.3g} s: " + " and ".join(why) if why else ""
