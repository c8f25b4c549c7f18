"""Data checks where data enter: units (CSV, arrays, streams), CSV time units, starts in motion, mag=None.

Each bad input is one warning or one ``error:`` line with exit 2 (``tests/tuner/test_errors.py`` style).
"""

import shutil
import warnings

import numpy as np
import pytest
import yaml

from objectives.attitude.data.csv import CSV_OPTIONS, TIME_UNITS, csv_keys, load_csv
from objectives.attitude.data.plausibility import (
    START_ACC_DEV,
    START_GYR_RAD_S,
    UnitWarning,
    motion_start,
    unit_messages,
    unit_warnings,
)
from objectives.attitude.data.recording import Recording, RecordingError
from objectives.attitude.data.synthetic import simulate_imu
from objectives.attitude.filters import filter_names, get_filter
from objectives.attitude.objective import FilterObjective
from objectives.attitude.quaternion import quat_from_euler_zyx
from tests.conftest import REPO as ROOT
from tests.conftest import one_error_line
from tests.conftest import run_tuner as tuner

EXAMPLES = ROOT / "configs" / "examples"
DT = 0.01


def _quat(t, rest_s=0.0):
    """(N, 4) quaternions: at rest until ``rest_s``, then roll, pitch and yaw swings (ZYX Euler angles)."""
    s = np.clip(t - rest_s, 0.0, None)
    return quat_from_euler_zyx(np.stack([0.6 * np.sin(1.7 * s), 0.4 * np.sin(1.1 * s), 2.0 * np.sin(0.5 * s)], 1))


@pytest.fixture(scope="module")
def rec():
    t = np.arange(400) * DT
    return simulate_imu(_quat(t, 1.0), DT, frame="ENU", rng=np.random.default_rng(3), gyr_noise=0.003,
                        acc_noise=0.05, mag_noise=0.002)


# --- units on the array API and streams: the CSV path's own check, once ----------------------------
def _caught(fn):
    with warnings.catch_warnings(record=True) as w:
        warnings.simplefilter("always")
        fn()
    return [x for x in w if issubclass(x.category, UnitWarning)]


def test_array_api_warns_once_as_the_csv_check(rec):
    flt = get_filter("madgwick")()
    assert _caught(lambda: flt.run(rec.gyr, rec.acc, rec.mag, rate_hz=100.0)) == []
    (w,) = _caught(lambda: flt.run(np.degrees(rec.gyr) * 20, rec.acc / 9.80665, rec.mag, rate_hz=100.0))
    # the same messages as the preflight's check on a recording with these arrays (one check, reused)
    bad = Recording("madgwick.run", np.degrees(rec.gyr) * 20, rec.acc / 9.80665, rec.mag, DT)
    assert str(w.message).startswith("; ".join(unit_warnings(bad)))
    assert "deg/s" in str(w.message) and "in g" in str(w.message)
    assert w.filename == __file__  # points at the caller's line
    (w,) = _caught(lambda: flt.run(rec.gyr, rec.acc / 9.80665, rec.mag, rate_hz=100.0))
    assert "acc" in str(w.message) and "gyr" not in str(w.message).split(";")[0].split(":")[1]


@pytest.mark.parametrize("name", ["madgwick", "ekf", "mahony1d"])
def test_stream_warns_once(name, rec):
    s = get_filter(name)().stream(rate_hz=100.0)
    ws = _caught(lambda: [s.update(g, a, m) for g, a, m in zip(rec.gyr[:150], rec.acc[:150] / 9.80665, rec.mag)])
    assert len(ws) == 1 and "in g" in str(ws[0].message) and f"{name}.stream" in str(ws[0].message)
    s = get_filter(name)().stream(rate_hz=100.0)
    assert _caught(lambda: [s.update(g, a, m) for g, a, m in zip(rec.gyr[:150], rec.acc[:150], rec.mag)]) == []


def test_stream_checks_its_first_hundred_samples():
    """Deg/s shows only once the sensor turns fast: the check on the first 100 samples sees it."""
    gyr = np.zeros((120, 3))
    gyr[50:, 2] = 200.0  # deg/s read as rad/s
    acc = np.tile([0.0, 0.0, 9.81], (120, 1))
    s = get_filter("mahony")().stream(rate_hz=100.0)
    ws = _caught(lambda: [s.update(g, a) for g, a in zip(gyr, acc)])
    assert len(ws) == 1 and "deg/s" in str(ws[0].message)


def test_unit_messages_thresholds():
    acc = np.tile([0.0, 0.0, 9.81], (10, 1))
    assert unit_messages("x", np.full((10, 3), 20.0), acc) == []  # 35 rad/s norm: below 35
    assert len(unit_messages("x", np.full((10, 3), 21.0), acc)) == 1  # 36.4 rad/s norm
    assert unit_messages("x", np.zeros((10, 3)), acc * 0.21) == []  # 2.06: outside (0.5, 2.0)
    assert len(unit_messages("x", np.zeros((10, 3)), acc * 0.19)) == 1


# --- mag=None runs the IMU-only version (README) ----------------------------------------------------
@pytest.mark.parametrize("name", [n for n in filter_names() if "use_mag" in get_filter(n).defaults])
def test_mag_none_is_the_imu_only_filter(name, rec):
    cls = get_filter(name)
    q = cls().run(rec.gyr, rec.acc, None, rate_hz=100.0)
    ref = cls(use_mag=False).run(rec.gyr, rec.acc, rec.mag, rate_hz=100.0)
    np.testing.assert_array_equal(q, ref)
    s = cls().stream(rate_hz=100.0)
    last = [s.update(g, a) for g, a in zip(rec.gyr[:30], rec.acc[:30])][-1]
    np.testing.assert_allclose(last, cls(use_mag=False).run(rec.gyr[:30], rec.acc[:30], rate_hz=100.0)[-1],
                               atol=1e-12)


@pytest.mark.parametrize("name", [n for n in filter_names() if get_filter(n).needs_mag
                                  and "use_mag" not in get_filter(n).defaults])
def test_mag_none_on_a_9d_only_filter_names_the_magnetometer(name, rec):
    with pytest.raises(ValueError, match=f"{name}: needs a magnetometer"):
        get_filter(name)().run(rec.gyr, rec.acc, rate_hz=100.0)
    with pytest.raises(ValueError, match="needs a magnetometer"):
        get_filter(name)().stream(rate_hz=100.0).update(rec.gyr[0], rec.acc[0])


# --- CSV time units -----------------------------------------------------------------------------------
def _write_csv(path, t, n=50):
    rows = ["t,gx,gy,gz,ax,ay,az"] + [f"{float(t[i])!r},0,0,0,0,0,9.81" for i in range(n)]
    path.write_text("\n".join(rows) + "\n")
    return path


COLS = {"time": "t", "gyr": ["gx", "gy", "gz"], "acc": ["ax", "ay", "az"]}


@pytest.mark.parametrize("step, unit, ok", [(3.5, "s", False), (3.5, "ms", True), (0.9, "s", True),
                                            (1.1, "s", False), (1.1e-5, "s", True), (0.99e-5, "s", False),
                                            (3.5e6, "ns", True), (3.5, "us", False)])
def test_csv_time_unit_rate_bounds(tmp_path, step, unit, ok):
    p = _write_csv(tmp_path / "a.csv", 1000.0 + np.arange(50) * step)
    if ok:
        rec = load_csv(p, COLS, time_unit=unit)
        assert 1.0 <= 1.0 / rec.dt <= 1e5
    else:
        with pytest.raises(RecordingError, match=f"time_unit: '{unit}' makes the time column 't' imply") as e:
            load_csv(p, COLS, time_unit=unit)
        assert all(u in str(e.value) for u in TIME_UNITS)


def test_csv_ms_read_as_seconds_is_one_error_line(tmp_path):
    """The issue's case: ms stamps at 286 Hz read as seconds (0.29 Hz)."""
    _write_csv(tmp_path / "imu.csv", 5000.0 + np.arange(50) * 3.5)
    cfg = {"name": "t", "seed": 1, "objective": {"kind": "filter", "filter": "madgwick", "metric": "euler_rmse_mean",
                                                   "data": [{"csv": {"path": "imu.csv", "columns": COLS}}]},
           "optimizer": {"method": "pso", "population": 4, "generations": 2}, "parallel": {"backend": "serial"}}
    (tmp_path / "job.yaml").write_text(yaml.safe_dump(cfg))
    out = tuner("run", "job.yaml", cwd=tmp_path)
    one_error_line(out, "objective.data[0]", "time_unit", "0.2857 Hz", "s, ms, us, ns", "'ms' it would be 285.7 Hz")
    assert not (tmp_path / "runs").exists()


def test_describe_csv_lists_every_key_and_allowed_value():
    keys = csv_keys()
    assert [k["name"] for k in keys] == ["path", "columns", *CSV_OPTIONS]
    out = tuner("describe", "csv")
    assert out.returncode == 0, out.stderr
    for k in keys:
        assert k["name"] in out.stdout
    from objectives.attitude.data.csv import ACC_UNITS, GYR_UNITS

    for v in [*GYR_UNITS, *ACC_UNITS, *TIME_UNITS, "ENU", "NED", "sensor_to_earth", "earth_to_sensor", "quat (4)"]:
        assert v in out.stdout, v


# --- the example job for one's own CSV -------------------------------------------------------------
def test_example_csv_is_what_its_generator_writes(tmp_path, monkeypatch):
    monkeypatch.syspath_prepend(str(EXAMPLES))
    import make_imu_csv

    assert make_imu_csv.main(tmp_path / "imu.csv").read_text() == (EXAMPLES / "imu.csv").read_text()


def test_example_job_on_own_csv_runs(tmp_path):
    for f in ("own_csv.yaml", "imu_columns.yaml", "imu.csv"):
        shutil.copy(EXAMPLES / f, tmp_path / f)
    out = tuner("run", "own_csv.yaml", "--set", "optimizer.generations=2", "--no-report", cwd=tmp_path)
    assert out.returncode == 0, out.stderr
    assert "warning" not in out.stderr  # units declared right, starts at rest
    from objectives.attitude.data.loaders import load_recordings

    (r,) = load_recordings({"csv": {"path": "imu.csv", "columns": "imu_columns.yaml"}}, tmp_path)
    assert r.dt == pytest.approx(0.02) and unit_warnings(r) == [] and motion_start(r) == ""
    assert np.isnan(r.quat).any(axis=1).sum() == 7  # the mocap dropouts stay NaN rows
    assert np.median(np.linalg.norm(r.acc[:50], axis=1)) == pytest.approx(9.81, abs=0.1)  # g -> m/s^2


# --- a start in motion under an accmag/broad start ----------------------------------------------------
def test_motion_start_thresholds_both_sides():
    n = 100
    acc = np.tile([0.0, 0.0, 9.80665], (n, 1))
    gyr = np.zeros((n, 3))
    for g, moving in ((0.9 * START_GYR_RAD_S, False), (1.1 * START_GYR_RAD_S, True)):
        gyr[:, 0] = g
        assert bool(motion_start(Recording("r", gyr, acc, None, DT))) is moving
    gyr[:] = 0.0
    for d, moving in ((0.9 * START_ACC_DEV, False), (1.1 * START_ACC_DEV, True)):
        a = acc.copy()
        a[:, 2] += d
        assert bool(motion_start(Recording("r", gyr, a, None, DT))) is moving
    late = Recording("r", np.vstack([np.zeros((50, 3)), np.ones((50, 3))]), acc, None, DT)
    assert motion_start(late) == ""  # only the first 0.25 s count


CSV_MAP = {"time": "t", "gyr": ["gyr_x", "gyr_y", "gyr_z"], "acc": ["acc_x", "acc_y", "acc_z"],
           "mag": ["mag_x", "mag_y", "mag_z"], "quat": ["q_w", "q_x", "q_y", "q_z"]}


def _objective(tmp_path, recs, **kw):
    from objectives.attitude.data.export_csv import to_csv

    specs = []
    for name, r in recs.items():
        to_csv(r, tmp_path / f"{name}.csv")
        specs.append({"csv": {"path": f"{name}.csv", "columns": CSV_MAP}})
    return FilterObjective.from_config({"kind": "filter", "filter": "madgwick", "data": specs, **kw}, tmp_path)


@pytest.fixture(scope="module")
def moving_and_resting():
    t = np.arange(300) * DT
    mk = dict(frame="ENU", gyr_noise=0.003, acc_noise=0.05, mag_noise=0.002)
    return {"moving": simulate_imu(_quat(t), DT, rng=np.random.default_rng(1), **mk),
            "resting": simulate_imu(_quat(t, 1.0), DT, rng=np.random.default_rng(2), **mk)}


@pytest.mark.parametrize("kw, warned", [({}, True), ({"q0": "truth"}, False), ({"fixed": {"init": "truth"}}, False),
                                        ({"fixed": {"init": "broad"}}, True), ({"warmup_s": 1.0}, False),
                                        ({"q0": "truth", "fixed": {"init": "accmag"}}, True)])
def test_start_in_motion_warns_naming_recording_and_fix(tmp_path, moving_and_resting, kw, warned):
    obj = _objective(tmp_path, moving_and_resting, **kw)
    ws = [w for w in obj.preflight() if "starts in motion" in w]
    if not warned:
        assert ws == []
        return
    (w,) = ws
    assert w.startswith("moving: starts in motion") and "init: truth" in w and "warmup_s" in w


def test_broad_segment_starting_in_motion_warns(broad_dir):
    """The issue's case: a ``start_s`` segment that starts in motion (BROAD trial 01 moves at 60 s); the one from
    the start (at rest, then moving: a window at rest only has nothing to score) does not warn."""
    specs = [{"broad": {"dir": str(broad_dir), "trial": "01_undisturbed_slow_rotation_A", **cut}}
             for cut in ({"start_s": 60.0, "stop_s": 70.0}, {"start_s": 0.0, "stop_s": 70.0})]
    obj = FilterObjective.from_config({"kind": "filter", "filter": "mahony", "data": specs,
                                       "fixed": {"init": "broad"}}, ROOT)
    ws = [w for w in obj.preflight() if "starts in motion" in w]
    assert len(ws) == 1 and "01_undisturbed_slow_rotation_A" in ws[0] and "broad start" in ws[0]


def test_readme_five_line_csv_job_is_the_example():
    """The README's data section opens with the five lines of ``configs/examples/own_csv.yaml``."""
    readme = (ROOT / "README.md").read_text()
    section = readme.split("## Your own data\n", 1)[1]
    assert section.lstrip().startswith("Your own CSV in five lines")
    block = section.split("```yaml\n", 1)[1].split("```", 1)[0]
    assert len(block.strip().splitlines()) == 5
    doc = yaml.safe_load(block)
    job = yaml.safe_load((EXAMPLES / "own_csv.yaml").read_text())
    assert doc["parameters"] == job["parameters"]
    assert {k: job["objective"][k] for k in doc["objective"]} == doc["objective"]
    assert "maps/imu.yaml" not in readme and "examples/imu_columns.yaml" in readme


def test_start_in_motion_is_one_warning_line_of_tuner_run(tmp_path, moving_and_resting):
    from objectives.attitude.data.export_csv import to_csv

    to_csv(moving_and_resting["moving"], tmp_path / "moving.csv")
    cfg = {"name": "m", "seed": 1, "objective": {"kind": "filter", "filter": "madgwick", "metric": "euler_rmse_mean",
                                                   "data": [{"csv": {"path": "moving.csv", "columns": CSV_MAP}}]},
           "optimizer": {"method": "pso", "population": 4, "generations": 1}, "parallel": {"backend": "serial"}}
    (tmp_path / "job.yaml").write_text(yaml.safe_dump(cfg))
    out = tuner("run", "job.yaml", "--no-report", cwd=tmp_path)
    assert out.returncode == 0, out.stderr
    lines = [ln for ln in out.stderr.splitlines() if ln.startswith("warning:")]
    assert len(lines) == 1 and lines[0].startswith("warning: moving: starts in motion"), lines
    assert "init: truth" in lines[0] and "warmup_s" in lines[0]


def test_evaluate_on_new_data_starting_in_motion_warns(tmp_path, moving_and_resting):
    """``tuner evaluate CONFIG --params p --data new.yaml``: the new data's start is checked too."""
    from objectives.attitude.data.export_csv import to_csv

    to_csv(moving_and_resting["moving"], tmp_path / "moving.csv")
    to_csv(moving_and_resting["resting"], tmp_path / "resting.csv")
    cfg = {"name": "m", "seed": 1, "objective": {"kind": "filter", "filter": "madgwick", "metric": "euler_rmse_mean",
                                                   "data": [{"csv": {"path": "resting.csv", "columns": CSV_MAP}}]},
           "parameters": {"beta": {"low": 0.01, "high": 0.5, "scale": "log"}},
           "optimizer": {"method": "pso", "population": 4, "generations": 1}}
    (tmp_path / "job.yaml").write_text(yaml.safe_dump(cfg))
    (tmp_path / "p.yaml").write_text("beta: 0.05\n")
    (tmp_path / "new.yaml").write_text(yaml.safe_dump([{"csv": {"path": "moving.csv", "columns": CSV_MAP}}]))
    out = tuner("evaluate", "job.yaml", "--params", "p.yaml", "--data", "new.yaml", "--json", cwd=tmp_path)
    assert out.returncode == 0, out.stderr
    (w,) = [ln for ln in out.stderr.splitlines() if ln.startswith("warning:")]
    assert "moving: starts in motion" in w
    import json

    assert json.loads(out.stdout)["warnings"] == [w.removeprefix("warning: ")]
    out = tuner("evaluate", "job.yaml", "--params", "p.yaml", cwd=tmp_path)
    assert out.returncode == 0 and "warning" not in out.stderr, out.stderr
