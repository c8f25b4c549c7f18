"""The ``rosbag:`` data source: bags written with rosbags' own writers (ROS 1, ROS 2 sqlite3 and MCAP) read with
topics and frames only, against the recording they were written from and the same data as CSV."""

from __future__ import annotations

import csv as csv_module
import json
from pathlib import Path

import numpy as np
import pytest
import yaml

pytest.importorskip("rosbags")

from objectives.attitude.data.bench6dof import bench6dof  # noqa: E402
from objectives.attitude.data.loaders import load_recording  # noqa: E402
from objectives.attitude.data.recording import RecordingError  # noqa: E402
from objectives.attitude.quaternion import Q_ENU_FROM_NWU, qconj, qmul_batch  # noqa: E402
from tests.attitude.rosbag_cases import CSV_COLUMNS, FORMATS, stamps_ns, write_bag, write_csv  # noqa: E402
from tests.conftest import run_tuner  # noqa: E402


@pytest.fixture(scope="module")
def rec():
    return bench6dof(duration_s=8.0, rate_hz=100.0, seed=3, frame="ENU")


def _bag(tmp_path: Path, rec, fmt: str, **kw) -> Path:
    return write_bag(tmp_path / ("run.bag" if fmt == "ros1" else f"run_{fmt}"), rec, fmt, **kw)


@pytest.mark.parametrize("fmt", FORMATS)
def test_bag_read_with_topics_only_equals_its_recording_and_csv(tmp_path, rec, fmt):
    bag = _bag(tmp_path, rec, fmt)
    got = load_recording({"rosbag": {"path": str(bag), "mag": "/imu/mag", "truth": "/truth"}})
    csv = load_recording({"csv": {"path": str(write_csv(tmp_path / "run.csv", rec)), "columns": CSV_COLUMNS}})
    assert got.n == rec.n and got.frame == "ENU" and got.units["mag"] == "uT"
    np.testing.assert_array_equal(got.gyr, rec.gyr)
    np.testing.assert_array_equal(got.acc, rec.acc)
    np.testing.assert_array_equal(got.quat, rec.quat)
    np.testing.assert_allclose(got.mag, rec.mag, rtol=1e-15, atol=1e-12)  # tesla in the bag, uT read
    for name in ("gyr", "acc", "mag", "quat", "time"):
        np.testing.assert_array_equal(getattr(got, name), getattr(csv, name), err_msg=name)
    assert got.dt == csv.dt
    t_ns = stamps_ns(rec)
    assert got.meta["rosbag"] == {"imu_frame_id": "imu_link", "first_stamp_ns": int(t_ns[0]), "world_frame": "ENU"}


@pytest.mark.parametrize("truth", ["odom", "transform", "tf"])
def test_truth_from_odometry_transform_and_tf(tmp_path, rec, truth):
    bag = _bag(tmp_path, rec, "sqlite3", truth=truth, extra_tf_child="base_link")
    topic = "/tf" if truth == "tf" else "/truth"
    got = load_recording({"rosbag": {"path": str(bag), "truth": topic, "truth_child_frame": "imu_link"}})
    np.testing.assert_array_equal(got.quat, rec.quat)
    assert got.mag is None  # no mag topic named: none read
    if truth == "tf":
        with pytest.raises(RecordingError, match=r"truth_child_frame: needed .*\['base_link', 'imu_link'\]"):
            load_recording({"rosbag": {"path": str(bag), "truth": "/tf"}})
        with pytest.raises(RecordingError, match=r"no transform with child frame 'marker'.*\['base_link', 'imu"):
            load_recording({"rosbag": {"path": str(bag), "truth": "/tf", "truth_child_frame": "marker"}})


def test_world_frames_nwu_turned_to_enu_and_ned_kept(tmp_path, rec):
    # the same motion with its truth in NWU: q_nwu = conj(Q_ENU_FROM_NWU) * q_enu
    q_nwu = qmul_batch(qconj(np.asarray(Q_ENU_FROM_NWU, float)), rec.quat)
    bag = _bag(tmp_path, rec, "mcap", truth_quat=q_nwu)
    got = load_recording({"rosbag": {"path": str(bag), "truth": "/truth", "world_frame": "nwu"}})
    assert got.frame == "ENU" and got.meta["rosbag"]["world_frame"] == "NWU"
    np.testing.assert_allclose(got.quat, rec.quat, atol=1e-14)
    # read as ENU the NWU truth is off by 90 deg of heading: the frame option is what makes it right
    wrong = load_recording({"rosbag": {"path": str(bag), "truth": "/truth"}})
    d = np.abs(np.sum(wrong.quat * rec.quat, axis=1))
    np.testing.assert_allclose(2 * np.degrees(np.arccos(np.clip(d, 0, 1))), 90.0, atol=1e-6)
    ned = load_recording({"rosbag": {"path": str(bag), "truth": "/truth", "world_frame": "NED"}})
    assert ned.frame == "NED"
    np.testing.assert_array_equal(ned.quat, q_nwu)


def test_magnetometer_on_its_own_stamps_interpolated(tmp_path, rec):
    off_ns = 3_000_000  # the magnetometer 3 ms after each IMU sample
    bag = _bag(tmp_path, rec, "ros1", mag_offset_ns=off_ns)
    got = load_recording({"rosbag": {"path": str(bag), "mag": "/imu/mag"}})
    assert got.n == rec.n - 1  # the first IMU sample precedes the magnetometer's first: dropped, said
    assert any("dropped 1 IMU message(s) outside the magnetometer" in w for w in got.meta["warnings"])
    t_imu = stamps_ns(rec)[1:]
    t_mag = stamps_ns(rec, off_ns)
    mag = (rec.mag * 1e-6) * 1e6
    u = (t_imu - t_mag[:-1]) / (t_mag[1:] - t_mag[:-1])  # 0.7: 7 ms of the 10 ms between two mag samples
    np.testing.assert_allclose(u, 0.7, atol=1e-9)
    expected = mag[:-1] + u[:, None] * (mag[1:] - mag[:-1])
    np.testing.assert_allclose(got.mag, expected, rtol=0, atol=1e-9 * np.abs(mag).max())
    np.testing.assert_array_equal(got.gyr, rec.gyr[1:])


def test_truth_between_stamps_is_slerped_and_gaps_are_nan(tmp_path, rec):
    # truth only every 4th sample, and a gap of 0.2 s (longer than max_truth_gap_s 0.05) in the middle
    from objectives.attitude.data.timebase import slerp

    bag = _bag(tmp_path, rec, "sqlite3")
    got = load_recording({"rosbag": {"path": str(bag), "truth": "/truth", "resample_hz": 50.0,
                                     "max_truth_gap_s": 0.05}})
    assert got.dt == 1 / 50.0 and got.meta["read"].resampled_hz == 50.0
    t = (stamps_ns(rec) - stamps_ns(rec)[0]) * 1e-9
    np.testing.assert_allclose(got.quat, slerp(t, rec.quat, got.time), atol=1e-15)


def test_align_options_as_for_csv(tmp_path, rec):
    bag = _bag(tmp_path, rec, "mcap")
    align = {"lag": 0.02, "body": "none", "heading": "none"}
    got = load_recording({"rosbag": {"path": str(bag), "truth": "/truth", "mag": "/imu/mag", "align": align}})
    csv = load_recording({"csv": {"path": str(write_csv(tmp_path / "run.csv", rec)), "columns": CSV_COLUMNS,
                                  "align": align}})
    assert got.meta["alignment"].lag_s == pytest.approx(0.02)
    np.testing.assert_array_equal(got.quat, csv.quat)
    assert np.isnan(got.quat[-1]).all() and np.isfinite(got.quat[0]).all()


def test_errors_name_the_bag_and_the_key(tmp_path, rec):
    bag = _bag(tmp_path, rec, "mcap")
    cases = [
        ({"truth": "/pose"}, r"truth: topic '/pose' not in the bag; it has /imu \(sensor_msgs/msg/Imu\)"),
        ({"mag": "/truth"}, r"mag: topic '/truth' carries geometry_msgs/msg/PoseStamped; allowed: sensor_msgs/msg/Ma"),
        ({"world_frame": "ECEF"}, r"world_frame: 'ECEF' is not one of ENU, NED, NWU"),
        ({"stamps": "arrival"}, r"stamps: 'arrival' is not one of header, bag"),
        ({"align": {"lag": "auto"}}, r"align: needs the truth"),
        ({"resample_hz": -1}, r"resample_hz: expected a rate in Hz > 0"),
    ]
    for opts, msg in cases:
        with pytest.raises(RecordingError, match=msg):
            load_recording({"rosbag": {"path": str(bag), **opts}})
    with pytest.raises(RecordingError, match=r"unknown key\(s\) \['topic'\]"):
        load_recording({"rosbag": {"path": str(bag), "topic": "/imu"}})
    with pytest.raises(RecordingError, match="path: not found"):
        load_recording({"rosbag": {"path": str(tmp_path / "nope.bag")}})
    (tmp_path / "text.bag").write_text("not a bag")
    with pytest.raises(RecordingError, match="path: not a readable ROS bag"):
        load_recording({"rosbag": {"path": str(tmp_path / "text.bag")}})
    two = _bag(tmp_path / "x", rec, "ros1") if (tmp_path / "x").mkdir() is None else None
    got = load_recording({"rosbag": {"path": str(two), "stamps": "bag"}})  # the one Imu topic, by default
    np.testing.assert_array_equal(got.gyr, rec.gyr)


def test_without_rosbags_one_error_names_the_extra(tmp_path, monkeypatch):
    import builtins

    real = builtins.__import__

    def no_rosbags(name, *a, **k):
        if name.startswith("rosbags"):
            raise ImportError(name)
        return real(name, *a, **k)

    monkeypatch.setattr(builtins, "__import__", no_rosbags)
    (tmp_path / "b.bag").write_bytes(b"")
    with pytest.raises(RecordingError, match=r"needs the optional package rosbags: pip install 'attitude-tuner\[ros"):
        load_recording({"rosbag": {"path": str(tmp_path / "b.bag")}})


def test_bag_command_lists_topics_and_describe_lists_keys(tmp_path, rec):
    bag = _bag(tmp_path, rec, "ros1", truth="tf")
    r = run_tuner("bag", str(bag))
    assert r.returncode == 0, r.stderr
    lines = r.stdout.splitlines()
    assert any(ln.startswith("/imu ") and "sensor_msgs/msg/Imu" in ln and "800 msgs" in ln and "100 Hz" in ln
               and "{imu: /imu}" in ln for ln in lines), r.stdout
    assert any(ln.startswith("/tf ") and "tf2_msgs/msg/TFMessage" in ln and "{truth: /tf}" in ln for ln in lines)
    js = json.loads(run_tuner("bag", str(bag), "--json").stdout)
    assert [t["topic"] for t in js] == ["/imu", "/imu/mag", "/tf"] and js[1]["use"] == "mag"
    bad = run_tuner("bag", str(tmp_path / "none.bag"))
    assert bad.returncode == 2 and bad.stderr.startswith("error: ") and len(bad.stderr.strip().splitlines()) == 1
    d = run_tuner("describe", "rosbag")
    assert d.returncode == 0, d.stderr
    for key in ("truth_child_frame", "world_frame", "stamps", "resample_hz", "align", "start_s"):
        assert key in d.stdout


@pytest.mark.slow
@pytest.mark.parametrize("fmt", ["ros1", "mcap"])
def test_tuning_on_a_bag_equals_tuning_on_the_same_data_as_csv(tmp_path, rec, fmt):
    from tuner.config import config_from_dict
    from tuner.run import run

    bag = _bag(tmp_path, rec, fmt)
    csv = write_csv(tmp_path / "run.csv", rec)
    specs = {"bag": {"rosbag": {"path": str(bag), "mag": "/imu/mag", "truth": "/truth", "name": "run"}},
             "csv": {"csv": {"path": str(csv), "columns": CSV_COLUMNS, "name": "run"}}}
    best = {}
    for key, spec in specs.items():
        raw = {"name": f"bag-{key}", "seed": 3,
               "objective": {"kind": "filter", "filter": "madgwick", "data": [spec], "warmup_s": 1.0,
                             "report": {"traces": False}},
               "optimizer": {"method": "pso", "population": 6, "generations": 3},
               "parallel": {"backend": "serial", "n_jobs": 1}}
        res = run(config_from_dict(raw, base_dir=tmp_path), run_dir=tmp_path / key, quiet=True, report=False)
        assert res.status == "finished"
        best[key] = yaml.safe_load((tmp_path / key / "best.yaml").read_text())
        with open(tmp_path / key / "history.csv", newline="") as fh:
            best[key]["history"] = [{k: v for k, v in row.items() if k != "seconds"}  # wall time
                                    for row in csv_module.DictReader(fh)]
    assert best["bag"]["params"] == best["csv"]["params"]
    assert best["bag"]["fitness"] == best["csv"]["fitness"]
    assert len(best["bag"]["history"]) == 18
    assert best["bag"]["history"] == best["csv"]["history"]
