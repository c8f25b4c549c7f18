"""The 1-D tilt test bench of the thesis (Odry 2020), section 3.1.2."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from objectives.attitude.data import bench_common as bench
from objectives.attitude.data.imu_model import _check_frame, simulate_imu
from objectives.attitude.data.recording import Recording

__all__ = ["tilt1d", "TILT1D_SENSOR"]

#: Default sensor model of :func:`tilt1d` with ``noise=True``: the thesis robot's L3G4200D gyroscope
#: (0.03 deg/s/sqrt(Hz) datasheet noise density) and LIS331DL accelerometer (8 bit, +-2 g, 18 mg
#: per digit). The thesis gives no noise numbers of its own (eqs. 3.2-3.4 define only the units);
#: the bias is chosen to match its reported gyro drift (about 15 deg after 100 s, 40 deg after 300 s),
#: the accelerometer noise density (not in the LIS331DL datasheet) is a documented choice.
TILT1D_SENSOR = {
    "gyr_noise": 5.24e-4,      # rad/s/sqrt(Hz)  (0.03 deg/s/sqrt(Hz))
    "gyr_bias_max": 2.6e-3,    # rad/s  (0.15 deg/s), initial bias uniform in +-this
    "gyr_bias_walk": 2.0e-5,   # rad/s^2/sqrt(Hz)
    "acc_noise": 2.2e-3,       # m/s^2/sqrt(Hz)  (about 220 ug/sqrt(Hz))
    "acc_resolution_g": 0.018,  # g per digit (quantisation)
    "acc_range_g": 2.0,        # saturation
}

_TILT_PHASES = (0, 1, 2, 3, 5)   # static, calm, vibrating, accelerating, vibrating+accelerating


def tilt1d(
    duration_s: float = 60.0,
    rate_hz: float = 800.0,
    seed: int = 0,
    *,
    noise: bool = True,
    frame: str = "NED",
    vibration: bool = True,
    external_acc: bool = True,
    vib_freq_range_hz: tuple[float, float] = (0.5, 6.5),
    ext_acc_max_g: float = 1.5,
    phase_s: tuple[float, float] = (4.0, 10.0),
    with_mag: bool = False,
    **sensor_overrides,
) -> Recording:
    """Synthetic recording of the thesis's 1-D tilt test bench (Odry 2020, section 3.1.2).

    The robot body (an inverted pendulum between the motors) oscillates about the wheel axle while
    the plate carrying the axle slides horizontally. Here:

    - rotation about the sensor **y** axis only: ``quat = (cos(a/2), 0, sin(a/2), 0)`` with the tilt
      angle ``a`` (rad, ``extra["angle"]``), positive by the right-hand rule about y (in NED a
      positive tilt lifts the sensor's x axis); ``gyr[:, 1]`` is the tilt rate, ``gyr[:, 0]`` and
      ``gyr[:, 2]`` carry only noise and bias;
    - external acceleration along the earth **x** axis (north in NED, east in ENU), within
      ``+-ext_acc_max_g * g`` (thesis: +-1.5 g); ``acc[:, 0]`` and ``acc[:, 2]`` carry gravity plus
      this acceleration, ``acc[:, 1]`` only noise;
    - body oscillation with frequency varying in ``vib_freq_range_hz`` (thesis: 0-6.5 Hz),
      amplitude 0.05-0.5 rad capped so the rate stays within 800 deg/s (thesis: +-800 deg/s);
      slow tilt within +-0.5 rad; phases as in :func:`bench6dof` without the magnetic ones;
    - 800 Hz sampling (thesis: "the sampling frequency is 800 Hz"); sensors of
      :data:`TILT1D_SENSOR` when ``noise`` (including 18 mg quantisation and +-2 g saturation of
      the 8-bit accelerometer).

    The thesis measures the accelerometer tilt as ``atan2(A_y, A_z)`` in its own axes; with the
    axes here the same realisation is ``atan2(acc_x, -acc_z)`` in NED and ``atan2(-acc_x, acc_z)``
    in ENU (both equal ``a`` without external acceleration and noise).

    Parameters
    ----------
    duration_s, rate_hz, seed, frame, noise, vibration, external_acc
        As in :func:`bench6dof`.
    vib_freq_range_hz, ext_acc_max_g, phase_s
        Ranges described above.
    with_mag : bool
        Also simulate a magnetometer (unit field); default no magnetometer (``mag`` is None).
    **sensor_overrides
        Keywords of :func:`simulate_imu` (see :func:`bench6dof`) plus ``acc_resolution_g`` and
        ``acc_range_g`` (None: no quantisation / saturation).

    Returns
    -------
    Recording
        ``extra``: ``angle`` (N,) rad, ``true_ext_acc`` (N, 3) m/s^2 earth frame, ``vib_freq_hz``
        (N,), ``phase`` (N,), ``true_gyr``, ``gyr_bias`` (N, 3).
    """
    _check_frame(frame)
    bench._check_overrides("tilt1d", sensor_overrides, bench._SENSOR_KEYS + ("acc_resolution_g", "acc_range_g"))
    n, dt = bench._check_duration(duration_s, rate_hz)
    if ext_acc_max_g < 0:
        raise ValueError(f"ext_acc_max_g must be >= 0, got {ext_acc_max_g!r}")
    r_sched, r_slow, r_vib, r_acc, r_sens = (
        np.random.default_rng(s) for s in np.random.SeedSequence(seed).spawn(5))
    codes, _ = bench._schedule(n, dt, r_sched, phase_s, _TILT_PHASES)
    env = bench._phase_envelopes(codes, dt, vibration, external_acc)
    env_vib, env_acc = env.vibration, env.external_acc

    sensor = bench._sensor_model(TILT1D_SENSOR, noise, r_sens, sensor_overrides)
    g = float(sensor.get("g", 9.81))
    res_g = sensor.pop("acc_resolution_g", None)
    range_g = sensor.pop("acc_range_g", None)

    slow = bench._slow_angles(n, dt, r_slow, np.array([0.5]), env.speed)[:, 0]
    # oscillation rate capped at 740 deg/s so that with the slow tilt (< 1.3 rad/s) |rate| < 800 deg/s
    vib, f_vib = bench._oscillation(n, dt, r_vib, vib_freq_range_hz, (0.05, 0.5), math.radians(740.0), 1)
    angle = slow + env_vib * vib[:, 0]
    quat = np.zeros((n, 4))
    quat[:, 0] = np.cos(angle / 2)
    quat[:, 2] = np.sin(angle / 2)
    ext = np.zeros((n, 3))
    ext[:, 0] = env_acc * bench._translation_acc(n, dt, r_acc, ext_acc_max_g * g, 1)[:, 0]
    if not with_mag:
        sensor.setdefault("mag_field", False)
    spec = f"tilt1d(duration_s={duration_s}, rate_hz={rate_hz}, seed={seed}, noise={noise})"
    rec = simulate_imu(
        quat, dt, frame=frame, rng=r_sens, ext_acc=ext, name=f"tilt1d-{seed}", source=spec,
        extra={"angle": angle, "vib_freq_hz": np.where(env_vib > 0.5, f_vib, 0.0),
               "phase": codes.astype(float)},
        **sensor,
    )
    if res_g is None and range_g is None:
        return rec
    acc = rec.acc
    if res_g is not None:
        lsb = float(res_g) * g
        acc = np.round(acc / lsb) * lsb
    if range_g is not None:
        acc = np.clip(acc, -float(range_g) * g, float(range_g) * g)
    return replace(rec, acc=acc)


