"""Write ``lab.csv``, another lab's log for ``lab_csv.yaml`` (run from anywhere; deterministic, ~1 MB, not kept in git).

40 s of an IMU and an optical reference as a motion-capture logger writes them (the project's bench6dof motion
and sensors, :func:`objectives.attitude.data.lablog.lab_log`): a comment line, a semicolon-separated two-line
header (names in merged cells, then units), stamps in ms with jitter, 20 rows written twice, a 0.19 s gap, a
50 Hz IMU logged at 90 Hz (sample-and-hold), a gyroscope reading 3 % low, and a marker quaternion 13.7 ms late,
turned 180 deg (plus a 2.5 deg tilt) from the IMU, in a camera frame 37 deg off magnetic north, with two
dropouts, a zero row and three flipped rows. It starts at rest for 15 s.
"""

from pathlib import Path

from objectives.attitude.data.lablog import lab_log


def main(path: Path | None = None):
    """Write the CSV to ``path`` (default: ``lab.csv`` beside this file); return what it was written with."""
    return lab_log(Path(__file__).with_name("lab.csv") if path is None else Path(path), duration_s=40.0)


if __name__ == "__main__":
    print(main())
