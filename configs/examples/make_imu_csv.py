"""Write ``imu.csv``, the small example recording of ``own_csv.yaml`` (run from anywhere; deterministic).

6 s at 50 Hz of a simulated IMU in the units loggers often write: time stamps in ms, gyro in deg/s,
accelerometer in g, magnetometer in uT, and a motion-capture quaternion (w, x, y, z, sensor to earth,
ENU) with two short dropouts (empty cells). It starts at rest for 1 s, then tilts and turns.
"""

from pathlib import Path

import numpy as np

from objectives.attitude.data.synthetic import simulate_imu
from objectives.attitude.quaternion import quat_from_euler_zyx

RATE_HZ = 50.0


def trajectory(t: np.ndarray) -> np.ndarray:
    """(N, 4) quaternions: at rest until 1 s, then roll, pitch and yaw swings (ZYX Euler angles)."""
    s = np.clip(t - 1.0, 0.0, None)
    return quat_from_euler_zyx(np.stack([0.5 * np.sin(1.9 * s), 0.35 * np.sin(1.3 * s), 1.5 * np.sin(0.6 * s)], 1))


def main(path: Path | None = None) -> Path:
    """Write the CSV to ``path`` (default: ``imu.csv`` beside this file) and return the path."""
    path = Path(__file__).with_name("imu.csv") if path is None else Path(path)
    t = np.arange(int(6 * RATE_HZ)) / RATE_HZ
    rec = simulate_imu(trajectory(t), 1.0 / RATE_HZ, frame="ENU", rng=np.random.default_rng(24), gyr_noise=0.004,
                       acc_noise=0.03, mag_noise=0.003, gyr_bias=(0.004, -0.003, 0.002))
    quat = rec.quat.copy()
    quat[120:124] = np.nan  # mocap dropouts
    quat[200:203] = np.nan
    rows = ["time_ms,gx_dps,gy_dps,gz_dps,ax_g,ay_g,az_g,mx_uT,my_uT,mz_uT,qw,qx,qy,qz"]
    for i in range(rec.n):
        vals = [f"{1_000_000 + 1000 * t[i]:.1f}", *(f"{v:.4f}" for v in np.degrees(rec.gyr[i])),
                *(f"{v:.5f}" for v in rec.acc[i] / 9.80665), *(f"{v:.3f}" for v in 50.0 * rec.mag[i]),
                *("" if not np.isfinite(v) else f"{v:.6f}" for v in quat[i])]
        rows.append(",".join(vals))
    path.write_text("\n".join(rows) + "\n")
    return path


if __name__ == "__main__":
    print(main())
