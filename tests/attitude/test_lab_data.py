"""Another lab's recordings read with options only: file layout, stamps, sample-and-hold, resampling, truth
sanity and the alignment of the truth to the IMU (issue #39, items 1 and 2).

The synthetic logs come from :func:`objectives.attitude.data.lablog.lab_log` (the project's bench6dof motion
and sensors, written with a known lag, misalignment, heading offset, gyro scale, jitter, duplicate stamps,
sample-and-hold and a two-line header); every estimate is checked against the value the log was written with.
"""

from __future__ import annotations

import argparse
import math
import re

import numpy as np
import pandas as pd
import pytest
import yaml

from objectives.attitude.align_command import ALIGN, align_rows
from objectives.attitude.data.alignment import AlignSpec, alignments, estimate_alignment
from objectives.attitude.data.bench6dof import bench6dof
from objectives.attitude.data.csv import load_csv
from objectives.attitude.data.csv_table import column_names, read_table
from objectives.attitude.data.imu_model import body_rate
from objectives.attitude.data.lablog import LAB_COLUMNS, lab_log
from objectives.attitude.data.loaders import load_recording
from objectives.attitude.data.recording import RecordingError
from objectives.attitude.data.timebase import body_rates as truth_rates
from objectives.attitude.data.timebase import (
    held_rows,
    imu_clock,
    increasing,
    resample_imu,
    slerp,
    truth_sanity,
)
from objectives.attitude.quaternion import qconj_batch, qmul_batch, quat_from_euler_zyx

LAYOUT = {k: v for k, v in LAB_COLUMNS.items() if k != "columns"}
ALIGN_ALL = {"lag": "auto", "body": "auto", "heading": "start"}


def _angle_deg(p, q) -> np.ndarray:
    d = qmul_batch(np.atleast_2d(np.asarray(p, float)), qconj_batch(np.atleast_2d(np.asarray(q, float))))
    return np.degrees(2.0 * np.arccos(np.clip(np.abs(d[:, 0]), 0.0, 1.0)))


# --- the file's layout --------------------------------------------------------------------------------------
def test_names_from_merged_cells_follow_pandas_for_repeats(tmp_path):
    assert column_names(["time", "gyro", "", "", "acc", " ", "", "gyro"]) == \
        ["time", "gyro", "gyro.1", "gyro.2", "acc", "acc.1", "acc.2", "gyro.3"]
    assert column_names(["", "a"], ncols=4) == ["col1", "a", "a.1", "a.2"]
    # names repeated in the header: the rule is pandas' own (the independent reference)
    p = tmp_path / "rep.csv"
    p.write_text("x,x,y,x\n1,2,3,4\n")
    assert column_names(["x", "x", "y", "x"]) == list(pd.read_csv(p).columns)


def test_layout_two_header_rows_semicolon_decimal_comma_comments(tmp_path):
    p = tmp_path / "log.csv"
    p.write_text("# logger 2.1\n\n# channels\nt;gyr;;;acc;;\nms;dps;dps;dps;g;g;g\n"
                 "0;1,5;2;3;0;0;1\n# paused\n10;1,25;2;3;0;0;1,0\n20;oops;2;3;0;0;1\n")
    table = read_table(p, delimiter=";", header_rows=2, decimal=",", comment="#")
    assert table.names == ["t", "gyr", "gyr.1", "gyr.2", "acc", "acc.1", "acc.2"] and len(table) == 3
    assert table.frame["gyr.1"].tolist() == [2, 2, 2] and table.frame["acc.2"].tolist() == [1.0, 1.0, 1.0]
    cols = {"time": "t", "gyr": ["gyr", "gyr.1", "gyr.2"], "acc": ["acc", "acc.1", "acc.2"]}
    with pytest.raises(RecordingError, match=r"log\.csv: column 'gyr' row 3: 'oops' is not a number"):
        load_csv(p, cols, delimiter=";", header_rows=2, decimal=",", comment="#", time_unit="ms")
    p.write_text(p.read_text().replace("20;oops", "20;1,75"))
    rec = load_csv(p, cols, delimiter=";", header_rows=2, decimal=",", comment="#", time_unit="ms",
                   gyr_unit="deg/s", acc_unit="g")
    np.testing.assert_allclose(np.degrees(rec.gyr[:, 0]), [1.5, 1.25, 1.75])
    assert rec.dt == pytest.approx(0.01)


@pytest.mark.parametrize("opts, match", [
    ({"delimiter": ";;"}, r"delimiter: expected one character"),
    ({"header_rows": 9}, r"header_rows: 9, but the file has 3 non-empty line"),
    ({"header_rows": 1, "names_row": 2}, r"names_row: 2 is not one of the 1 header row"),
    ({"decimal": ";"}, r"decimal: expected '\.' or ','"),
    ({"comment": "##"}, r"comment: expected one character"),
    ({"max_dropped_share": 2}, r"max_dropped_share: expected a number in \[0, 1\]"),
    ({"resample_hz": 0}, r"resample_hz: expected a rate in Hz > 0"),
    ({"max_truth_gap_s": -1}, r"max_truth_gap_s: expected a number of seconds > 0"),
    ({"quat_norm_tol": 1.5}, r"quat_norm_tol: expected a number in \(0, 1\)"),
    ({"truth_rate_factor": 0.5}, r"truth_rate_factor: expected a number >= 1"),
    ({"align": {"lag": "soon"}}, r"align\.lag: expected auto or a number of seconds, got 'soon'"),
    ({"align": {"body": [1, 0, 0]}}, r"align\.body: expected auto, none or a unit quaternion"),
    ({"align": {"heading": "north"}}, r"align\.heading: expected start, mean or none"),
    ({"align": {"lags": "auto"}}, r"align\.lags: unknown key; allowed: lag, body, heading, max_lag_s"),
])
def test_bad_options_name_file_and_key(tmp_path, opts, match):
    p = tmp_path / "imu.csv"
    p.write_text("t,gx,gy,gz,ax,ay,az,qw,qx,qy,qz\n0,0,0,0,0,0,9.8,1,0,0,0\n0.01,0,0,0,0,0,9.8,1,0,0,0\n")
    cols = {"time": "t", "gyr": ["gx", "gy", "gz"], "acc": ["ax", "ay", "az"], "quat": ["qw", "qx", "qy", "qz"]}
    with pytest.raises(RecordingError, match=r"imu\.csv: " + match):
        load_csv(p, cols, **opts)


def test_wrong_delimiter_says_which_one(tmp_path):
    p = tmp_path / "semi.csv"
    p.write_text("t;gx;gy;gz;ax;ay;az\n0;0;0;0;0;0;9.8\n")
    with pytest.raises(RecordingError, match=r"column 't' \(for 'time'\) not found.*set delimiter: ';'"):
        load_csv(p, {"time": "t", "gyr": ["gx", "gy", "gz"], "acc": ["ax", "ay", "az"]})


# --- stamps, sample-and-hold, resampling, slerp, truth sanity -----------------------------------------------
def test_increasing_keeps_each_stamp_after_every_one_before():
    rng = np.random.default_rng(1)
    t = np.cumsum(rng.choice([-0.01, 0.0, 0.01, 0.01, 0.01], 500))
    want, top = [], -math.inf  # slow reference: a loop over the rows
    for v in t:
        want.append(v > top)
        top = max(top, v)
    np.testing.assert_array_equal(increasing(t), want)


def test_slerp_matches_scipy_and_leaves_gaps_nan():
    from scipy.spatial.transform import Rotation, Slerp

    rng = np.random.default_rng(2)
    t = np.cumsum(rng.uniform(0.005, 0.02, 200))
    q = quat_from_euler_zyx(np.cumsum(rng.normal(0, 0.05, (200, 3)), axis=0))
    q[::7] *= -1  # sign flips: the same rotations
    tq = np.sort(rng.uniform(t[0], t[-1], 1000))
    ours = slerp(t, q, tq)
    ref = Slerp(t, Rotation.from_quat(q[:, [1, 2, 3, 0]]))(tq).as_quat()[:, [3, 0, 1, 2]]
    assert _angle_deg(ours, ref).max() < 1e-5
    np.testing.assert_allclose(np.linalg.norm(ours, axis=1), 1.0, atol=1e-12)
    gappy = t.copy()
    gappy[100:] += 0.5  # one step of 0.5 s
    out = slerp(gappy, q, np.array([gappy[99] + 0.1, gappy[100], t[0] - 1.0, gappy[-1] + 1.0]), max_gap_s=0.1)
    assert np.isnan(out[0]).all() and np.isfinite(out[1]).all() and np.isnan(out[2:]).all()


def test_truth_rates_are_the_gyro_convention():
    q = bench6dof(duration_s=4.0, rate_hz=200.0, seed=4, frame="ENU", noise=False).quat
    t = np.arange(q.shape[0]) / 200.0
    mid, w = truth_rates(t, q)
    np.testing.assert_allclose(w, body_rate(q, 1 / 200.0)[:-1], atol=1e-9)
    np.testing.assert_allclose(mid, t[:-1] + 0.0025)


def test_sample_and_hold_clock_and_resampling():
    """An IMU at 51 Hz logged at 90 Hz: its own rate and sample times are recovered from the held rows, and a
    linear signal resamples exactly (the gyroscope read at interval middles, the project's convention)."""
    tau = np.arange(510) / 51.0 + 0.003
    ticks = np.arange(int(9.9 * 90)) / 90.0 + 0.02
    k = np.searchsorted(tau, ticks, side="right") - 1
    ok = k >= 0
    ticks, k = ticks[ok], k[ok]
    imu = np.column_stack([np.sin(tau), np.cos(3 * tau), tau])[k]
    held = held_rows(imu)
    assert held.mean() == pytest.approx(1 - 51 / 90, abs=0.01)
    ts, period = imu_clock(ticks, held, True)
    assert 1 / period == pytest.approx(51.0, rel=2e-3)
    err = (ts - tau[k[~held]])[1:]  # the first sample waited for the log to start
    assert abs(err.mean()) < 0.5e-3 and np.abs(err).max() < 0.5 / 90 + 1e-9  # unbiased, within half a log period
    t_imu = np.arange(50) * 0.02
    lin = {"gyr": np.column_stack([2.0 + 3.0 * (t_imu + 0.01)] * 3), "acc": np.column_stack([1.0 - t_imu] * 3),
           "mag": None, "motion": (np.arange(50) % 2 == 0)}
    grid, out = resample_imu(t_imu, 0.02, lin, 100.0)
    assert grid.shape == (99,) and out["mag"] is None
    # the first grid interval's middle lies before the first sample's: the end value holds there
    np.testing.assert_allclose(out["gyr"][1:-1, 0], 2.0 + 3.0 * (grid[1:-1] + 0.005), atol=1e-12)
    np.testing.assert_allclose(out["acc"][:, 1], 1.0 - grid, atol=1e-12)
    np.testing.assert_array_equal(out["motion"], np.arange(99) // 2 % 2 == 0)


def test_truth_sanity_counts_norms_spikes_and_jumps():
    t = np.arange(400) * 0.01
    q = quat_from_euler_zyx(np.column_stack([0.3 * np.sin(t), 0.2 * np.cos(t), 0.5 * t]))
    gyr = np.full(400, 0.6)  # rad/s, about the truth's rate
    q[50] = 0.0  # a lost marker written as zeros
    q[120] *= 1.3  # |q| = 1.3
    q[200] = qmul_batch(q[200:201], [[0.5, 0.0, 0.0, math.sqrt(0.75)]])[0]  # one row flipped by 120 deg: a spike
    q[300:] = qmul_batch(q[300:], [[0.0, 1.0, 0.0, 0.0]])  # a marker swap for good: one jump
    q[250] = np.nan
    out, n_norm, n_rate = truth_sanity(t, q, gyr, 0.1, 3.0)
    assert (n_norm, n_rate) == (2, 3)
    assert set(np.flatnonzero(~np.isfinite(out).all(axis=1))) == {50, 120, 200, 250, 299, 300}


# --- another lab's log, end to end ------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def level_log(tmp_path_factory):
    return lab_log(tmp_path_factory.mktemp("lab") / "lab.csv")


@pytest.fixture(scope="module")
def start_log(tmp_path_factory):
    """A truth relative to the marker's start pose, the truth early (negative lag), the marker 90 deg off."""
    return lab_log(tmp_path_factory.mktemp("lab") / "start.csv", seed=5, relative_to_start=True, lag_s=-0.0042,
                   body_deg=(90.0, -3.0), gyro_scale=1.02)


def _read(log, **opts):
    return load_csv(log.path, LAB_COLUMNS["columns"], **LAYOUT, **opts)


@pytest.mark.slow
@pytest.mark.parametrize("which", ["level_log", "start_log"])
def test_lab_log_read_with_options_only_estimates_within_1ms_and_01deg(which, request):
    log = request.getfixturevalue(which)
    rec = _read(log, resample_hz=100, align=ALIGN_ALL)
    a, read = rec.meta["alignment"], rec.meta["read"]
    assert abs(a.lag_s - log.lag_s) < 1e-3
    assert _angle_deg(a.body, log.body)[0] < 0.1
    assert _angle_deg(a.frame, log.frame)[0] < 0.1
    assert abs(a.heading_offset_deg - log.heading_deg) < 0.1
    assert a.gyro_scale == pytest.approx(log.gyro_scale, abs=2e-3)
    np.testing.assert_allclose(a.gyro_scale_axes, log.gyro_scale, atol=3e-3)
    assert a.estimated == ("lag", "body", "heading")
    assert read.imu_rate_hz == pytest.approx(log.imu_rate_hz, abs=0.05)
    assert read.log_rate_hz == pytest.approx(log.log_rate_hz, rel=0.01)
    assert (read.dropped_stamps, read.truth_nan_norm, read.truth_nan_rate) == (log.duplicates, log.zero_quaternions,
                                                                              log.spikes)
    assert rec.dt == 0.01 and read.resampled_hz == 100
    # the aligned truth is the sensor's own orientation: compare with the motion the log was written from
    fine = bench6dof(duration_s=61.5, rate_hz=1000.0, seed=5 if which == "start_log" else 3, frame="ENU",
                     vibration=False, start_static_s=15.5, gyr_scale=(log.gyro_scale - 1.0,) * 3)
    q_true = slerp(np.arange(fine.n) / 1000.0, fine.quat, read.start_s + rec.time)
    err = _angle_deg(rec.quat[np.isfinite(rec.quat).all(axis=1)], q_true[np.isfinite(rec.quat).all(axis=1)])
    assert np.percentile(err, 99) < 0.1 and err.max() < 0.2
    assert rec.meta["warnings"] and all(w.startswith(str(log.path)) for w in rec.meta["warnings"])
    assert alignments([rec, _read(log, resample_hz=100)]) == {"lab" if which == "level_log" else "start": a.as_dict()}


@pytest.mark.slow
def test_lab_log_warnings_and_the_error_without_resampling(level_log):
    rec = _read(level_log, resample_hz=100)
    warnings = "\n".join(rec.meta["warnings"])
    for text in ("dropped 20 of", "repeat the previous IMU sample: the IMU runs at 50", "the log at 89.",
                 "1 truth row(s) set to NaN: a norm outside", "3 truth row(s) set to NaN: a step more than 3 times"):
        assert text in warnings, text
    assert "alignment" not in rec.meta
    with pytest.raises(RecordingError, match=r"lab\.csv: 'time' is not uniformly sampled: .*set resample_hz \(the "
                                             r"IMU's own rate is 50(\.\d+)? Hz\) or raise jitter_tol"):
        _read(level_log)
    with pytest.raises(RecordingError, match=r"lab\.csv: time: 20 of 5402 rows .* more than max_dropped_share"):
        _read(level_log, resample_hz=100, max_dropped_share=0.001)


@pytest.mark.slow
def test_given_alignment_is_applied_as_given(level_log):
    a = _read(level_log, resample_hz=100, align={"lag": 0.0137, "body": list(level_log.body), "heading": "none"})
    al = a.meta["alignment"]
    assert al.lag_s == 0.0137 and al.body == pytest.approx(level_log.body) and al.estimated == ()
    assert al.frame == (1.0, 0.0, 0.0, 0.0) and al.gyro_scale == pytest.approx(0.97, abs=2e-3)
    b = _read(level_log, resample_hz=100)
    ok = np.isfinite(a.quat).all(axis=1) & np.isfinite(b.quat).all(axis=1)
    # the truth rotated by the given body, 37 deg of heading left: the angle between them is about the heading
    assert np.median(_angle_deg(a.quat[ok], b.quat[ok])) > 100
    heading = qmul_batch(np.asarray(level_log.frame), a.quat[ok])
    moved = np.median(_angle_deg(heading, _read(level_log, resample_hz=100, align=ALIGN_ALL).quat[ok]))
    assert moved < 0.1


def test_alignment_needs_motion_about_two_axes_and_a_magnetometer():
    t = np.arange(3000) * 0.01
    q = quat_from_euler_zyx(np.column_stack([0 * t, 0 * t, np.sin(t)]))  # a turn about z only
    gyr = body_rate(q, 0.01)
    acc = np.tile([0.0, 0.0, 9.81], (3000, 1))
    with pytest.raises(RecordingError, match=r"x\.csv: align\.body: auto needs rotation about at least two axes"):
        estimate_alignment(t, gyr, acc, None, t, q, AlignSpec(lag="auto", body="auto"), "ENU", where="x.csv: align")
    with pytest.raises(RecordingError, match=r"x\.csv: align\.heading: start needs the magnetometer"):
        estimate_alignment(t, gyr, acc, None, t, q, AlignSpec(heading="start"), "ENU", where="x.csv: align")
    with pytest.raises(RecordingError, match=r"x\.csv: align\.lag: auto needs motion"):
        estimate_alignment(t, 0 * gyr, acc, None, t, q, AlignSpec(lag="auto"), "ENU", where="x.csv: align")


def test_body_fit_matches_scipy_align_vectors():
    """The rotation of the similarity fit equals scipy's Kabsch solution on the same rates."""
    from scipy.spatial.transform import Rotation

    from objectives.attitude.data.alignment import _similarity

    rng = np.random.default_rng(6)
    w = rng.normal(size=(500, 3))
    r = Rotation.from_rotvec([0.3, -2.0, 1.1])
    y = 0.95 * r.apply(w) + [0.01, -0.02, 0.005] + rng.normal(0, 0.01, (500, 3))
    m, k, b, _ = _similarity(w, y, None)
    ref, _ = Rotation.align_vectors(y - y.mean(axis=0), w - w.mean(axis=0))
    assert (Rotation.from_matrix(m) * ref.inv()).magnitude() < 1e-9
    assert k == pytest.approx(0.95, abs=2e-3) and b == pytest.approx([0.01, -0.02, 0.005], abs=2e-3)


# --- tuner align ------------------------------------------------------------------------------------------
def _data_yaml(tmp_path, log, align=None, name=None):
    spec = {"path": str(log.path), **LAB_COLUMNS, "resample_hz": 100}
    if align:
        spec["align"] = align
    if name:
        spec["name"] = name
    p = tmp_path / "data.yaml"
    p.write_text(yaml.safe_dump({"data": [{"csv": spec}]}))
    return p


def _run_align(*argv):
    ap = argparse.ArgumentParser()
    ALIGN.add_arguments(ap)
    return ALIGN.run(ap.parse_args([str(a) for a in argv]))


@pytest.mark.slow
def test_align_command_prints_rates_lag_misalignment_heading_and_scale(tmp_path, level_log, capsys):
    assert ALIGN.name == "align" and ALIGN.help
    p = _data_yaml(tmp_path, level_log)
    assert _run_align(p) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[0].startswith("lab: 100 Hz (the IMU's own 50 Hz, the log 89.8 Hz); lag 13.")
    for text in ("misalignment 179.9", "heading offset 3", "gyro scale 0.9", "estimated, not applied"):
        assert text in out[0], text
    values = re.search(r"misalignment ([\d.]+) deg.*heading offset ([\d.]+) deg.*gyro scale ([\d.]+)", out[0])
    assert [float(v) for v in values.groups()] == pytest.approx([180.0, 37.0, 0.97], abs=0.05)
    assert out[1].startswith("  align: {lag: 0.013")
    rows = align_rows(_data_yaml(tmp_path, level_log, ALIGN_ALL, name="mine"))
    assert rows[0]["name"] == "mine" and rows[0]["applied"]
    assert abs(rows[0]["alignment"]["lag_s"] - level_log.lag_s) < 1e-3


def test_align_command_bad_input_is_one_error_line(tmp_path, capsys):
    p = tmp_path / "data.yaml"
    p.write_text("data: [{csv: {path: nothere.csv, columns: {gyr: [a, b, c], acc: [d, e, f]}}}]\n")
    assert _run_align(p) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith(f"error: {p}: data[0]: ") and "nothere.csv: file not found" in err[0]
    assert _run_align(tmp_path / "missing.yaml") == 2
    assert capsys.readouterr().err.startswith(f"error: {tmp_path / 'missing.yaml'}: align: file not found")


def test_align_spec_in_a_column_map_file_and_a_data_spec(tmp_path, level_log):
    """align: and the new layout keys are options like the units: in the spec or in the column map file."""
    (tmp_path / "map.yaml").write_text(yaml.safe_dump({**LAB_COLUMNS, "resample_hz": 100}))
    rec = load_recording({"csv": {"path": str(level_log.path), "columns": "map.yaml", "start_s": 20,
                                  "stop_s": 30, "align": {"lag": 0.0137}}}, tmp_path)
    assert rec.name == "lab@20s-30s" and rec.n == 1000 and rec.meta["alignment"].lag_s == 0.0137


@pytest.mark.slow
def test_the_preflight_prints_what_reading_found(level_log):
    """The run's preflight (what `tuner run` and `evaluate --data` print as warnings) carries the reading's lines."""
    from objectives.attitude.objective import FilterObjective

    spec = {"csv": {"path": str(level_log.path), **LAB_COLUMNS, "resample_hz": 100, "align": ALIGN_ALL}}
    warnings = FilterObjective("madgwick", [spec], metric="broad_mean_rmse", warmup_s=1.0).preflight()
    assert any("dropped 20 of 5402 rows" in w for w in warnings)
    assert any("the IMU runs at 50" in w for w in warnings)


@pytest.mark.slow
def test_the_readme_walks_the_lab_example(tmp_path, monkeypatch, capsys):
    """README "Another lab's data": the file make_lab_csv.py writes, `tuner align` on the job and the run print
    what the README shows."""
    import shutil

    from tests.conftest import REPO
    from tests.conftest import run_tuner as tuner

    examples = REPO / "configs" / "examples"
    monkeypatch.syspath_prepend(str(examples))
    import make_lab_csv

    make_lab_csv.main(tmp_path / "lab.csv")
    for f in ("lab_columns.yaml", "lab_csv.yaml"):
        shutil.copy(examples / f, tmp_path / f)
    readme = (REPO / "README.md").read_text()
    section = readme[readme.index("## Another lab's data"):readme.index("## Python API")]
    monkeypatch.chdir(tmp_path)
    assert _run_align("lab_csv.yaml") == 0
    first = capsys.readouterr().out.splitlines()[0]
    shown = section[section.index("lab@10s-28s: 100 Hz"):]
    assert " ".join(shown[:shown.index("```")].split()) == first
    head = "\n".join((tmp_path / "lab.csv").read_text().splitlines()[:5])
    assert [ln[:60] for ln in head.splitlines()] == [ln[:60] for ln in section.split("```")[1].strip().splitlines()]
    out = tuner("run", "lab_csv.yaml", "--no-report", cwd=tmp_path)
    assert out.returncode == 0, out.stderr
    for text in ("dropped 20 of 3602 rows (0.555 %) whose stamp is not after the one before them",
                 "the IMU runs at 50.01 Hz, the log at 89.85 Hz", "21 truth sample(s) NaN"):
        assert text in out.stderr, text
    scores = re.findall(r"madgwick\s+(train|test)\s+([\d.]+)", out.stdout)
    assert [(s, f"{float(v):.2f}") for s, v in scores] == [("train", "3.72"), ("test", "4.90")]
    assert "`broad_mean_rmse` 3.72 deg tuned, 4.90 deg held out" in " ".join(section.split())


def test_a_bad_align_value_in_a_job_is_one_error_line(tmp_path):
    import shutil

    from tests.conftest import REPO, one_error_line
    from tests.conftest import run_tuner as tuner

    for f in ("imu.csv", "imu_columns.yaml"):
        shutil.copy(REPO / "configs" / "examples" / f, tmp_path / f)
    cfg = {"name": "a", "seed": 1, "objective": {
        "kind": "filter", "filter": "madgwick", "metric": "broad_mean_rmse",
        "data": [{"csv": {"path": "imu.csv", "columns": "imu_columns.yaml", "align": {"lag": "soon"}}}]},
        "optimizer": {"method": "pso", "population": 4, "generations": 2}, "parallel": {"backend": "serial"}}
    (tmp_path / "job.yaml").write_text(yaml.safe_dump(cfg))
    one_error_line(tuner("run", "job.yaml", cwd=tmp_path), "job.yaml", "objective.data[0]", "imu.csv: align.lag: "
                   "expected auto or a number of seconds, got 'soon'")
    assert not (tmp_path / "runs").exists()


@pytest.mark.slow
def test_heading_mean_without_disturbances_and_a_short_rest(tmp_path):
    """heading: mean averages every sample: on a log that rests 2 s only (too short for start's precision) and has
    neither external accelerations nor field disturbances, it finds the frame within 0.05 deg."""
    log = lab_log(tmp_path / "calm.csv", seed=2, disturbances=False, start_static_s=2.0)
    a = _read(log, resample_hz=100, align={"lag": "auto", "body": "auto", "heading": "mean"}).meta["alignment"]
    assert _angle_deg(a.frame, log.frame)[0] < 0.05 and abs(a.heading_offset_deg - log.heading_deg) < 0.05
