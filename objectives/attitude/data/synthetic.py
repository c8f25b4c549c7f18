"""Synthetic IMU recordings with exact ground truth: one import for the sensor model and the benches.

Every random number comes from a :class:`numpy.random.Generator`; the same seed gives
bit-identical recordings. The code lives in one module per job; this module gathers their public
names:

- :func:`simulate_imu`, :func:`body_rate`, :func:`earth_gravity`, :func:`earth_field`: the sensor
  model of the FAEKF paper (Odry et al. 2020, Sensors 20, 803), eqs. 7 and 9
  (:mod:`objectives.attitude.data.imu_model`, which also states the integration convention).
- :func:`bench6dof`: the 6-DOF test bench of the FAEKF paper, section 5.1
  (:mod:`objectives.attitude.data.bench6dof`); :data:`PHASES`, the phase types of both benches
  (:mod:`objectives.attitude.data.bench_common`).
- :func:`tilt1d`: the 1-D tilt test bench of the thesis (Odry 2020), section 3.1.2
  (:mod:`objectives.attitude.data.tilt1d`).
- :func:`magnetic_perturbation`: the perturbation generator of the FAEKF paper, eq. 34
  (:mod:`objectives.attitude.data.magnetic`).
- :func:`synthetic`: a cached dispatcher by generator name (:mod:`objectives.attitude.data.cache`);
  :func:`to_csv` exports a recording (:mod:`objectives.attitude.data.export_csv`).

Quaternion helpers are those of :mod:`objectives.attitude.quaternion`.
"""

from __future__ import annotations

from objectives.attitude.data.bench6dof import BENCH6DOF_SENSOR, bench6dof
from objectives.attitude.data.bench_common import PHASES
from objectives.attitude.data.cache import GENERATOR_VERSION, GENERATORS, _cached, synthetic
from objectives.attitude.data.export_csv import csv_columns, to_csv
from objectives.attitude.data.imu_model import (
    DEFAULT_INCLINATION_DEG,
    body_rate,
    earth_field,
    earth_gravity,
    simulate_imu,
)
from objectives.attitude.data.magnetic import magnetic_perturbation
from objectives.attitude.data.tilt1d import TILT1D_SENSOR, tilt1d

__all__ = [
    "simulate_imu", "body_rate", "earth_gravity", "earth_field", "DEFAULT_INCLINATION_DEG", "bench6dof",
    "tilt1d", "magnetic_perturbation", "synthetic", "to_csv", "csv_columns", "PHASES", "GENERATORS",
    "GENERATOR_VERSION", "BENCH6DOF_SENSOR", "TILT1D_SENSOR", "_cached",
]
