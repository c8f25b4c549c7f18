"""Recording loaders: BROAD (.mat, .hdf5), CSV with column maps, the spec dispatcher, from_time."""

from __future__ import annotations

import math

import numpy as np
import pytest

from objectives.attitude.data import loaders
from objectives.attitude.data.broad import broad_trials, load_broad
from objectives.attitude.data.csv import load_csv
from objectives.attitude.data.recording import Recording, RecordingError

FIRST = "01_undisturbed_slow_rotation_A"


@pytest.fixture(scope="module")
def broad_all(broad_dir):
    return {p.stem: load_broad(p) for p in sorted(broad_dir.glob("*.mat"))}


def test_every_broad_file_loads(broad_all, broad_dir):
    assert len(broad_all) == len(broad_trials()) == len(list(broad_dir.glob("*.mat"))) > 0
    for name, rec in broad_all.items():
        assert rec.name == name and rec.frame == "ENU" and rec.units["mag"] == "uT"
        assert rec.dt == pytest.approx(0.0035, rel=1e-4)
        assert rec.n > 10000 and rec.quat.shape == (rec.n, 4)
        assert np.isfinite(rec.gyr).all() and np.isfinite(rec.acc).all() and np.isfinite(rec.mag).all()
        ok = np.isfinite(rec.quat).all(axis=1)
        assert 0.8 < ok.mean() <= 1.0  # markers lost sometimes, truth NaN there
        np.testing.assert_allclose(np.linalg.norm(rec.quat[ok], axis=1), 1.0, atol=1e-9)
        assert 0.3 < rec.motion.mean() < 0.9
        # at rest the accelerometer reads about +g (specific force, pointing up)
        assert 9.0 < np.median(np.linalg.norm(rec.acc, axis=1)) < 10.6


def _write_mat(path, rec, drop=None, **override):
    import scipy.io

    d = {"imu_gyr": rec.gyr, "imu_acc": rec.acc, "imu_mag": rec.mag, "opt_quat": rec.quat,
         "movement": rec.motion[:, None], "sampling_rate": np.array([[1 / rec.dt]])}
    d.update(override)
    if drop:
        del d[drop]
    scipy.io.savemat(str(path), d)
    return path


@pytest.fixture(scope="module")
def small(broad_all):
    return broad_all[FIRST].slice(0, 2000)


def test_broad_truncated_file_names_file_and_key(tmp_path, broad_dir):
    raw = (broad_dir / f"{FIRST}.mat").read_bytes()
    bad = tmp_path / "truncated.mat"
    bad.write_bytes(raw[: len(raw) // 2])
    with pytest.raises(RecordingError) as exc:
        load_broad(bad)
    msg = str(exc.value)
    assert str(bad) in msg and "key 'opt_quat'" in msg and "truncated" in msg


def test_broad_missing_key_names_file_and_key(tmp_path, small):
    p = _write_mat(tmp_path / "nogyr.mat", small, drop="imu_gyr")
    with pytest.raises(RecordingError, match=r"nogyr\.mat: missing key\(s\) \['imu_gyr'\]"):
        load_broad(p)


def test_broad_nan_in_gyr_names_file_and_key(tmp_path, small):
    gyr = small.gyr.copy()
    gyr[123, 1] = np.nan
    p = _write_mat(tmp_path / "nangyr.mat", small, imu_gyr=gyr)
    msg = r"nangyr\.mat: key 'imu_gyr' has 1 non-finite sample\(s\), first at index 123"
    with pytest.raises(RecordingError, match=msg):
        load_broad(p)


def test_broad_wrong_shape_and_round_trip(tmp_path, small):
    p = _write_mat(tmp_path / "shape.mat", small, imu_acc=small.acc[:, :2])
    with pytest.raises(RecordingError, match=r"shape\.mat: key 'imu_acc' must have shape \(N, 3\)"):
        load_broad(p)
    rec = load_broad(_write_mat(tmp_path / "ok.mat", small))
    np.testing.assert_array_equal(rec.gyr, small.gyr)
    np.testing.assert_array_equal(rec.quat, small.quat)
    np.testing.assert_array_equal(rec.motion, small.motion)


def test_broad_hdf5(tmp_path, small):
    h5py = pytest.importorskip("h5py")
    p = tmp_path / "trial.hdf5"
    with h5py.File(p, "w") as f:  # MATLAB layout: arrays stored transposed
        f["imu_gyr"] = small.gyr.T
        f["imu_acc"] = small.acc.T
        f["imu_mag"] = small.mag.T
        f["opt_quat"] = small.quat.T
        f["movement"] = small.motion[None, :].astype(float)
        f["sampling_rate"] = np.array([[1 / small.dt]])
    rec = load_broad(p)
    np.testing.assert_array_equal(rec.gyr, small.gyr)
    np.testing.assert_array_equal(rec.quat, small.quat)
    np.testing.assert_array_equal(rec.motion, small.motion)
    p.write_bytes(p.read_bytes()[:500])
    with pytest.raises(RecordingError, match="trial.hdf5"):
        load_broad(p)


# --- Recording.from_time --------------------------------------------------------------------------

def _imu(n):
    rng = np.random.default_rng(0)
    return rng.normal(size=(n, 3)), rng.normal(size=(n, 3)) + [0, 0, 9.81]


def test_from_time_derives_dt_and_checks_stamps():
    gyr, acc = _imu(50)
    t = 10.0 + 0.01 * np.arange(50) + np.random.default_rng(1).uniform(-2e-4, 2e-4, 50)
    rec = Recording.from_time(t, name="x", gyr=gyr, acc=acc, rate_hz=100)
    assert rec.dt == pytest.approx((t[-1] - t[0]) / 49)
    t2 = t.copy()
    t2[20] = t2[19]
    with pytest.raises(RecordingError, match="x: 'time' must increase strictly; sample 20"):
        Recording.from_time(t2, name="x", gyr=gyr, acc=acc)
    t3 = 0.01 * np.arange(50)
    t3[30:] += 0.005  # one gap of 1.5 dt
    with pytest.raises(RecordingError, match="not uniformly sampled: interval 29 -> 30"):
        Recording.from_time(t3, name="x", gyr=gyr, acc=acc)
    with pytest.raises(RecordingError, match="rate of 100 Hz, expected 200 Hz"):
        Recording.from_time(0.01 * np.arange(50), name="x", gyr=gyr, acc=acc, rate_hz=200)
    with pytest.raises(RecordingError, match="'time' has 49 samples, expected 50"):
        Recording.from_time(0.01 * np.arange(49), name="x", gyr=gyr, acc=acc)
    t4 = 0.01 * np.arange(50)
    t4[3] = np.nan
    with pytest.raises(RecordingError, match="non-finite stamps, first at index 3"):
        Recording.from_time(t4, name="x", gyr=gyr, acc=acc)


# --- CSV ---------------------------------------------------------------------------------------

COLS = {"time": "t", "gyr": ["gx", "gy", "gz"], "acc": ["ax", "ay", "az"], "mag": ["mx", "my", "mz"],
        "quat": ["qw", "qx", "qy", "qz"], "motion": "moving"}


def _csv(path, n=40, dt_ms=5.0, edit=None):
    rng = np.random.default_rng(2)
    q = rng.normal(size=(n, 4))  # a truth turning at 0.4 rad/s at most: plausible against the 36 deg/s gyro
    q = q[0] + 1e-3 * np.cumsum(q, axis=0)
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    rows = []
    for i in range(n):
        vals = [i * dt_ms, 10.0 * i, -20.0, 30.0, 0.0, 0.1, 1.0, 20.0, 0.0, -40.0, *q[i], i % 3 == 0]
        rows.append([f"{v:.17g}" if not isinstance(v, (bool, np.bool_)) else str(int(v)) for v in vals])
    if edit:
        edit(rows)
    header = "t,gx,gy,gz,ax,ay,az,mx,my,mz,qw,qx,qy,qz,moving,unused"
    path.write_text(header + "\n" + "\n".join(",".join(r) + ",x" for r in rows) + "\n")
    return path, q


def test_csv_units_and_columns(tmp_path):
    p, q = _csv(tmp_path / "log.csv")
    rec = load_csv(p, COLS, gyr_unit="deg/s", acc_unit="g", time_unit="ms", mag_unit="uT", frame="NED")
    assert rec.n == 40 and rec.dt == pytest.approx(0.005) and rec.frame == "NED" and rec.name == "log"
    np.testing.assert_allclose(rec.gyr[3], np.radians([30.0, -20.0, 30.0]))
    np.testing.assert_allclose(rec.acc[0], [0, 0.980665, 9.80665])
    np.testing.assert_allclose(rec.mag[0], [20.0, 0.0, -40.0])
    np.testing.assert_allclose(rec.quat, q, rtol=1e-15)
    np.testing.assert_array_equal(rec.motion, np.arange(40) % 3 == 0)
    assert rec.units == {"gyr": "rad/s", "acc": "m/s^2", "mag": "uT"}
    conj = load_csv(p, COLS, time_unit="ms", quat_convention="earth_to_sensor")
    np.testing.assert_allclose(conj.quat, q * [1, -1, -1, -1])
    no_time = {k: v for k, v in COLS.items() if k != "time"}
    assert load_csv(p, no_time, rate_hz=50).dt == pytest.approx(0.02)


def test_csv_errors_name_file_and_column(tmp_path):
    p, _ = _csv(tmp_path / "log.csv")
    with pytest.raises(RecordingError, match=r"log\.csv: column 'gyro_x' \(for 'gyr'\) not found"):
        load_csv(p, {**COLS, "gyr": ["gyro_x", "gy", "gz"]}, time_unit="ms")
    with pytest.raises(RecordingError, match=r"log\.csv: gyr_unit 'rpm'"):
        load_csv(p, COLS, gyr_unit="rpm")
    with pytest.raises(RecordingError, match=r"column map for 'quat' needs 4"):
        load_csv(p, {**COLS, "quat": ["qw", "qx"]})
    with pytest.raises(RecordingError, match="exactly one of 'rate_hz' or 'dt'"):
        load_csv(p, {k: v for k, v in COLS.items() if k != "time"})

    def nan_gyr(rows):
        rows[7][2] = ""

    p2, _ = _csv(tmp_path / "nan.csv", edit=nan_gyr)
    msg = r"nan\.csv: column 'gy' \(gyr\) has 1 empty or non-finite value\(s\), first at row 8"
    with pytest.raises(RecordingError, match=msg):
        load_csv(p2, COLS, time_unit="ms")

    def text(rows):
        rows[4][5] = "oops"

    p3, _ = _csv(tmp_path / "text.csv", edit=text)
    with pytest.raises(RecordingError, match=r"text\.csv: column 'ay' row 5: 'oops' is not a number"):
        load_csv(p3, COLS, time_unit="ms")

    def twice(rows):
        rows.insert(10, list(rows[9]))  # a logger glitch: row 10 written twice

    p4, _ = _csv(tmp_path / "time.csv", edit=twice)
    rec = load_csv(p4, COLS, time_unit="ms")  # the repeated stamp's row dropped, with one warning
    assert rec.n == 40 and rec.meta["read"].dropped_stamps == 1
    assert rec.meta["warnings"] == [f"{p4}: dropped 1 of 41 rows (2.44 %) whose stamp is not after the one before "
                                    "them (first at row 11: 0.045 s after 0.045 s)"]
    with pytest.raises(RecordingError, match=r"time\.csv: time: 1 of 41 rows .* more than max_dropped_share \(0\)"):
        load_csv(p4, COLS, time_unit="ms", max_dropped_share=0)

    def back(rows):
        rows[10][0] = rows[9][0]  # one stamp repeated, its row's own time lost: a gap of 2 dt after dropping it

    p5, _ = _csv(tmp_path / "gap.csv", edit=back)
    with pytest.raises(RecordingError, match=r"gap\.csv: 'time' is not uniformly sampled: interval 9 -> 10 is "
                                             r"0\.01 s.*; set resample_hz or raise jitter_tol"):
        load_csv(p5, COLS, time_unit="ms")

    def nan_truth(rows):
        rows[3][10] = "nan"

    p6, _ = _csv(tmp_path / "truth.csv", edit=nan_truth)
    rec = load_csv(p6, COLS, time_unit="ms")  # NaN truth is allowed: metrics skip it
    assert np.isnan(rec.quat[3, 0]) and np.isfinite(rec.quat[4]).all()


# --- dispatcher -----------------------------------------------------------------------------------

def test_load_recording_csv_with_yaml_map(tmp_path):
    p, _ = _csv(tmp_path / "log.csv")
    (tmp_path / "map.yaml").write_text(
        "columns:\n  time: t\n  gyr: [gx, gy, gz]\n  acc: [ax, ay, az]\n"
        "gyr_unit: deg/s\ntime_unit: ms\nframe: NED\n"
    )
    rec = loaders.load_recording({"csv": {"path": "log.csv", "columns": "map.yaml", "stop_s": 0.1}}, tmp_path)
    assert rec.n == 20 and rec.frame == "NED" and rec.quat is None
    assert rec.gyr[1, 0] == pytest.approx(math.radians(10))
    (tmp_path / "bad.yaml").write_text("columns: {gyr: [gx, gy, gz], acc: [ax, ay, az]}\ngyro_unit: deg/s\n")
    with pytest.raises(RecordingError, match=r"bad\.yaml: unknown key\(s\) \['gyro_unit'\]"):
        loaders.load_recording({"csv": {"path": "log.csv", "columns": "bad.yaml"}}, tmp_path)
    with pytest.raises(RecordingError, match=r"unknown key\(s\) \['colums'\]"):
        loaders.load_recording({"csv": {"path": "log.csv", "colums": {}}}, tmp_path)


def test_load_recording_broad_and_bad_specs(tmp_path, broad_dir):
    spec = {"broad": {"dir": str(broad_dir), "trial": FIRST, "start_s": 1.0, "stop_s": 3.0}}
    rec = loaders.load_recording(spec)
    assert rec.n == round(2.0 / 0.0035) and rec.name == f"{FIRST}@1s-3s"  # a window is named by its bounds
    recs = loaders.load_recordings({"broad": {"dir": str(broad_dir), "trials": [FIRST, FIRST], "stop_s": 1}})
    assert [r.n for r in recs] == [round(1 / 0.0035)] * 2 and recs[0].name == f"{FIRST}@0s-1s"
    assert loaders.load_recording({"broad": {"dir": str(broad_dir), "trial": FIRST, "start_s": 60}}).name == \
        f"{FIRST}@60s-end"
    with pytest.raises(RecordingError, match="trial 'nope' not found"):
        loaders.load_recording({"broad": {"dir": str(broad_dir), "trial": "nope"}})
    with pytest.raises(RecordingError, match="unknown kind 'matlab'"):
        loaders.load_recording({"matlab": {}})
    with pytest.raises(RecordingError, match="one key"):
        loaders.load_recording({"broad": {}, "csv": {}})
    with pytest.raises(RecordingError, match=r"select samples"):
        loaders.load_recording({"broad": {"trial": FIRST, "start_s": 5, "stop_s": 4}})


def test_load_recording_synthetic_is_dispatched_lazily(monkeypatch):
    import objectives.attitude.data.cache as syn

    seen = {}

    def fake(generator, **kwargs):
        seen.update(generator=generator, **kwargs)
        gyr, acc = _imu(10)
        return Recording(name=generator, gyr=gyr, acc=acc, mag=None, dt=0.01)

    monkeypatch.setattr(syn, "synthetic", fake, raising=False)
    rec = loaders.load_recording({"synthetic": {"generator": "bench6dof", "duration_s": 1, "seed": 3}})
    assert rec.name == "bench6dof" and seen == {"generator": "bench6dof", "duration_s": 1, "seed": 3}
    with pytest.raises(RecordingError, match="needs 'generator'"):
        loaders.load_recording({"synthetic": {"seed": 1}})
