"""Another lab's log, synthesised: an IMU and an optical reference written the way a logger writes them.

:func:`lab_log` writes a CSV file with the defects real recordings of other labs have, each with a known value,
so that reading it with options only (:mod:`objectives.attitude.data.csv`) can be checked against the truth:

- a comment line, a semicolon-separated two-line header: names in merged cells (``gyroscope;;;``), then units;
- stamps in ms with jitter, rows written twice (duplicate stamps) and a gap in the log;
- an IMU at ``imu_rate_hz`` logged at ``log_rate_hz`` (sample-and-hold: a row repeats the last IMU sample);
- a gyroscope reading ``gyro_scale`` times the true rate;
- a truth that lags the IMU by ``lag_s``, tracks a marker rotated by ``body`` from the sensor, in a frame whose
  heading is ``heading_deg`` off the IMU's (or relative to the start pose), with dropouts, a zero quaternion and
  spikes (a flipped marker solution for one row).

The motion, the sensors and their noise are :func:`objectives.attitude.data.bench6dof.bench6dof`'s at 1 kHz
(no vibration); the IMU's samples are its block means over each IMU period (the gyroscope over
``[t_k, t_k + T]``, the project's convention, the accelerometer and magnetometer centred on ``t_k``).
"""

from __future__ import annotations

import io
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

__all__ = ["LabLog", "lab_log", "LAB_COLUMNS"]

_FINE_HZ = 1000.0
#: the column map of the file :func:`lab_log` writes (a ``csv:`` spec's ``columns`` plus its layout and units)
LAB_COLUMNS = {
    "columns": {"time": "time", "gyr": ["gyroscope", "gyroscope.1", "gyroscope.2"],
                "acc": ["accelerometer", "accelerometer.1", "accelerometer.2"],
                "mag": ["magnetometer", "magnetometer.1", "magnetometer.2"],
                "quat": ["marker", "marker.1", "marker.2", "marker.3"]},
    "delimiter": ";", "header_rows": 2, "comment": "#",
    "time_unit": "ms", "gyr_unit": "deg/s", "acc_unit": "g", "mag_unit": "uT", "frame": "ENU",
}


@dataclass(frozen=True)
class LabLog:
    """The file :func:`lab_log` wrote and the values it was written with.

    path : the CSV file. lag_s : the truth's lag (s). body : sensor-to-marker rotation (w, x, y, z).
    frame : rotation from the truth's frame into the IMU's earth frame (w, x, y, z). heading_deg : its heading.
    gyro_scale : the gyroscope's reading over the true rate. imu_rate_hz, log_rate_hz : the IMU's and the log's
    rates. rows : data rows written. duplicates : rows written twice. dropouts, spikes : truth rows left empty,
    flipped. zero_quaternions : truth rows written as 0, 0, 0, 0.
    """

    path: Path
    lag_s: float
    body: tuple
    frame: tuple
    heading_deg: float
    gyro_scale: float
    imu_rate_hz: float
    log_rate_hz: float
    rows: int
    duplicates: int
    dropouts: int
    spikes: int
    zero_quaternions: int


def _axis_angle(axis, angle_deg: float) -> np.ndarray:
    a = np.asarray(axis, float)
    a = a / np.linalg.norm(a)
    h = math.radians(angle_deg) / 2.0
    return np.array([math.cos(h), *(math.sin(h) * a)])


def lab_log(path: str | Path, *, duration_s: float = 60.0, seed: int = 3, imu_rate_hz: float = 50.0,
            log_rate_hz: float = 90.0, lag_s: float = 0.0137, body_deg: tuple = (180.0, 2.5),
            heading_deg: float = 37.0, relative_to_start: bool = False, gyro_scale: float = 0.97,
            jitter_s: float = 0.002, duplicates: int = 20, gap_s: float = 0.19, dropouts: int = 2,
            spikes: int = 3, zero_quaternions: int = 1, start_static_s: float = 15.0,
            disturbances: bool = True) -> LabLog:
    """Write another lab's log (module docstring) to ``path`` and return what it was written with.

    Parameters
    ----------
    duration_s : float
        Length of the log, s.
    seed : int
        Seed of the motion, the sensors and every defect; same seed, same file.
    imu_rate_hz, log_rate_hz : float
        The IMU's rate (a divisor of 1000 Hz) and the log's (rows per second).
    lag_s : float
        The truth row stamped t shows the pose at t - lag_s.
    body_deg : (angle about x, tilt about y), deg
        The sensor-to-marker rotation: a turn about the sensor's x axis, then a tilt about y.
    heading_deg : float
        The truth frame's heading offset (a turn about the vertical); ignored with ``relative_to_start``.
    relative_to_start : bool
        The truth is relative to the marker's start pose (identity in the first row), not in a level frame.
    gyro_scale : float
        The gyroscope reads this times the true rate.
    jitter_s : float
        The log's stamps jitter uniformly by +- this, s.
    duplicates : int
        Rows written twice (same stamp and values).
    gap_s : float
        One gap in the log (no rows) of this length, s, in the second half.
    dropouts, spikes, zero_quaternions : int
        Truth rows left empty, written with the marker turned by 120 deg, written as zeros.
    start_static_s : float
        The log starts at rest for about this long, s.
    disturbances : bool
        bench6dof's external accelerations and magnetic disturbances (off: gravity and the earth's field only).
    """
    from objectives.attitude.data.bench6dof import bench6dof
    from objectives.attitude.data.timebase import slerp
    from objectives.attitude.quaternion import qconj_batch, qmul_batch

    step = int(round(_FINE_HZ / imu_rate_hz))
    if abs(_FINE_HZ / step - imu_rate_hz) > 1e-9:
        raise ValueError(f"imu_rate_hz must divide {_FINE_HZ:g} Hz, got {imu_rate_hz!r}")
    lead = 0.5  # s of motion before the first row: the lagged truth exists from the first row on
    rec = bench6dof(duration_s=duration_s + 2 * lead + 0.5, rate_hz=_FINE_HZ, seed=seed, frame="ENU",
                    vibration=False, start_static_s=start_static_s + lead, gyr_scale=(gyro_scale - 1.0,) * 3,
                    external_acc=disturbances, mag_perturbation=disturbances)
    rng = np.random.default_rng(np.random.SeedSequence([seed, 39]))
    t_fine = np.arange(rec.n) / _FINE_HZ
    n_imu = (rec.n - step) // step
    blocks = rec.gyr[: n_imu * step].reshape(n_imu, step, 3)
    gyr = blocks.mean(axis=1)  # the rate over [t_k, t_k + T]
    half = step // 2
    centred = np.arange(n_imu) * step - half
    idx = np.clip(centred[:, None] + np.arange(step)[None, :], 0, rec.n - 1)
    acc, mag = rec.acc[idx].mean(axis=1), rec.mag[idx].mean(axis=1)
    t_imu = np.arange(n_imu) * step / _FINE_HZ

    ticks = lead + np.arange(int(duration_s * log_rate_hz)) / log_rate_hz
    ticks = ticks + rng.uniform(-jitter_s, jitter_s, ticks.shape[0])
    g0 = lead + duration_s * rng.uniform(0.5, 0.8)
    ticks = ticks[(ticks < g0) | (ticks > g0 + gap_s)]
    k = np.searchsorted(t_imu, ticks, side="right") - 1  # the IMU's last sample: sample-and-hold

    q_b = qmul_batch(_axis_angle([1, 0, 0], body_deg[0]), _axis_angle([0, 1, 0], body_deg[1])).ravel()
    q_sensor = slerp(t_fine, rec.quat, ticks - lag_s)
    if relative_to_start:
        q_f = qmul_batch(q_sensor[0], qconj_batch(q_b)).ravel()
    else:
        q_f = _axis_angle([0, 0, 1], heading_deg)
    marker = qmul_batch(qconj_batch(q_f), qmul_batch(q_sensor, qconj_batch(q_b)))
    marker = np.where(marker[:, :1] < 0, -marker, marker)
    n = ticks.shape[0]
    picks = rng.choice(np.arange(int(0.2 * n), n - 2), size=dropouts + spikes + zero_quaternions, replace=False)
    drop, spike, zero = np.split(picks, [dropouts, dropouts + spikes])
    marker[spike] = qmul_batch(marker[spike], _axis_angle([0, 0, 1], 120.0))
    marker[zero] = 0.0

    marker[drop] = np.nan  # written as empty cells
    data = np.column_stack([ticks * 1e3, np.degrees(gyr[k]), acc[k] / 9.80665, 50.0 * mag[k], marker])
    twice = rng.choice(np.arange(1, n), size=duplicates, replace=False)
    data = np.repeat(data, np.where(np.isin(np.arange(n), twice), 2, 1), axis=0)
    buf = io.StringIO()
    np.savetxt(buf, data, fmt=["%.3f"] + ["%.7g"] * 13, delimiter=";", comments="",
               header="# exported by a motion-capture logger; IMU and marker in one table\n"
                      "time;gyroscope;;;accelerometer;;;magnetometer;;;marker;;;\n"
                      "ms;deg/s;deg/s;deg/s;g;g;g;uT;uT;uT;;;;")
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(buf.getvalue().replace("nan", ""))
    heading = math.degrees(2.0 * math.atan2(q_f[3], q_f[0]))
    return LabLog(path, float(lag_s), tuple(float(v) for v in q_b), tuple(float(v) for v in q_f),
                  (heading + 180.0) % 360.0 - 180.0, float(gyro_scale), float(imu_rate_hz), float(log_rate_hz),
                  n + duplicates, duplicates, dropouts, spikes, zero_quaternions)
