"""The sensor fingerprint: its statistics against the values a recording was generated with, its
comparison thresholds, and the warning every way new data meets a tuned run (evaluate --data, verify-c
--data, from_run().run(), stream())."""

import math
import shutil
import warnings

import numpy as np
import pytest
import yaml

from objectives.attitude import fingerprint as fp
from objectives.attitude.data.recording import Recording

SIG_G, SIG_A, DIP, NORM = 0.003, 0.02, 60.0, 48.0


def _rest(n=6000, rate=100.0, sig_g=SIG_G, sig_a=SIG_A, drift=0.0, seed=0):
    rng = np.random.default_rng(seed)
    t = np.arange(n) / rate
    slow = drift * np.sin(2 * math.pi * 0.05 * t)[:, None]  # a slow wander the noise estimate must ignore
    gyr = rng.normal(0.0, sig_g, (n, 3)) + slow
    acc = np.array([0.0, 0.0, 9.81]) + rng.normal(0.0, sig_a, (n, 3))
    field = NORM * np.array([0.0, math.cos(math.radians(DIP)), -math.sin(math.radians(DIP))])  # ENU, down is -z
    mag = field + rng.normal(0.0, 0.1, (n, 3))
    return Recording(name=f"rest{seed}", gyr=gyr, acc=acc, mag=mag, dt=1.0 / rate)


def test_statistics_match_what_the_recording_was_made_with():
    s = fp.recording_stats(_rest())
    assert s["rate_hz"] == pytest.approx(100.0)
    assert s["gyr_noise"] == pytest.approx(SIG_G, rel=0.03)  # 6000 samples: the estimate's spread is ~1 %
    assert s["acc_noise"] == pytest.approx(SIG_A, rel=0.03)
    assert s["mag_norm"] == pytest.approx(NORM, rel=0.01)
    assert s["mag_dip_deg"] == pytest.approx(DIP, abs=0.3)


def test_noise_at_rest_ignores_a_slow_wander():
    rec = _rest(drift=0.02)  # a wander 7x the noise: the plain standard deviation would be ~5x too large
    assert np.std(rec.gyr[:, 0]) > 3 * SIG_G
    assert fp.recording_stats(rec)["gyr_noise"] == pytest.approx(SIG_G, rel=0.05)


def test_motion_range_is_the_95th_percentile_of_the_rate():
    n = 2000
    gyr = np.zeros((n, 3))
    gyr[:, 2] = np.linspace(0.0, 2.0, n)  # uniform 0..2 rad/s: its 95th percentile is 1.9 rad/s
    rec = Recording(name="spin", gyr=gyr, acc=np.tile([0.0, 0.0, 9.81], (n, 1)), mag=None, dt=0.01)
    s = fp.recording_stats(rec)
    assert s["gyr_p95_dps"] == pytest.approx(math.degrees(1.9), rel=1e-3)
    assert s["mag_norm"] is None and s["mag_dip_deg"] is None


def test_compare_names_what_differs_beyond_its_threshold():
    base = fp.fingerprint([_rest(seed=1), _rest(seed=2)])
    assert fp.compare(base, fp.fingerprint([_rest(seed=3)])) is None  # the same sensor, other noise draws
    assert fp.compare(None, base) is None  # a run without a fingerprint (an older tuner)
    other = fp.fingerprint([_rest(rate=51.0, sig_g=3 * SIG_G, seed=3)])
    line = fp.compare(base, other)
    assert line is not None and "\n" not in line
    assert "rate_hz 51 Hz vs 100 Hz" in line and "gyr_noise" in line
    assert "acc_noise" not in line and "mag_dip_deg" not in line
    # inside the thresholds: a rate 15 % off (limit x1.2) and a noise 1.8x (limit x2) are not reported
    assert fp.compare(base, fp.fingerprint([_rest(rate=115.0, sig_g=1.8 * SIG_G, seed=4)])) is None
    assert set(base["thresholds"]) == set(fp.THRESHOLDS) and base["summary"][0].startswith("sensor fingerprint:")


# --- a run stores it, new data is compared with it ---------------------------------------------------
def _synthetic(rate):
    return {"synthetic": {"generator": "bench6dof", "duration_s": 4.0, "rate_hz": rate, "seed": 1}}


@pytest.fixture(scope="module")
def tuned(tmp_path_factory):
    from tuner.config import config_from_dict
    from tuner.run import run

    tmp = tmp_path_factory.mktemp("fingerprint")
    raw = {"name": "fp", "seed": 5, "objective": {"kind": "filter", "filter": "madgwick", "data": [_synthetic(200.0)]},
           "optimizer": {"method": "pso", "population": 3, "generations": 1}, "parallel": {"backend": "serial"}}
    lines = []
    out = run(config_from_dict(raw, base_dir=tmp), run_dir=tmp / "fp", progress=lines.append, report=False).run_dir
    for rate in (200.0, 100.0):
        (tmp / f"data{int(rate)}.yaml").write_text(yaml.safe_dump({"data": [_synthetic(rate)]}))
    return out, tmp, lines


def test_a_run_stores_and_prints_its_fingerprint(tuned):
    from tuner.rundir import RunDir

    run_dir, _, lines = tuned
    doc = RunDir(run_dir).fingerprint()
    assert doc["stats"]["rate_hz"] == pytest.approx(200.0)
    assert any(line.startswith("sensor fingerprint: rate_hz 200 Hz") for line in lines)


def test_evaluate_on_other_data_warns_once(tuned):
    from tuner.rescore import evaluate_target

    run_dir, tmp, _ = tuned
    same = evaluate_target(run_dir, data_file=tmp / "data200.yaml")
    assert not any("tuned on" in w for w in same.get("warnings", []))
    other = [w for w in evaluate_target(run_dir, data_file=tmp / "data100.yaml")["warnings"] if "tuned on" in w]
    assert len(other) == 1 and "rate_hz 100 Hz vs 200 Hz" in other[0]


def test_from_run_and_stream_warn_on_another_rate(tuned):
    from objectives.attitude.data.synthetic import synthetic
    from objectives.attitude.filters.base import AttitudeFilter

    run_dir, _, _ = tuned
    flt = AttitudeFilter.from_run(run_dir)
    rec = synthetic("bench6dof", duration_s=4.0, rate_hz=100.0, seed=1)
    with pytest.warns(UserWarning, match="rate_hz 100 Hz vs 200 Hz"):
        flt.run(rec.gyr, rec.acc, rec.mag, rate_hz=100.0)
    with pytest.warns(UserWarning, match="rate_hz 100 Hz vs 200 Hz"):
        flt.stream(rate_hz=100.0)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        flt.stream(rate_hz=200.0)
        same = synthetic("bench6dof", duration_s=4.0, rate_hz=200.0, seed=1)
        flt.run(same.gyr, same.acc, same.mag, rate_hz=200.0)


@pytest.mark.skipif(shutil.which("cc") is None, reason="no C compiler")
def test_verify_c_on_other_data_warns(tuned):
    from tuner.export import verify_c

    run_dir, tmp, _ = tuned
    out = verify_c(run_dir, tmp / "data100.yaml")
    assert any("rate_hz 100 Hz vs 200 Hz" in w for w in out.get("warnings", []))


def test_alignment_estimates_are_stored_and_printed():
    import dataclasses

    from objectives.attitude.data.alignment import Alignment

    rec = _rest()
    est = Alignment(lag_s=0.0137, body_angle_deg=180.0, heading_offset_deg=37.0, gyro_scale=0.97)
    rec = dataclasses.replace(rec, meta={**dict(rec.meta or {}), "alignment": est})
    doc = fp.fingerprint([rec])
    assert doc["alignment"][rec.name]["lag_s"] == 0.0137
    assert doc["summary"][1] == (f"alignment {rec.name}: lag_s 0.0137 s, body_angle_deg 180 deg, heading_offset_deg "
                                 "37 deg, frame_tilt_deg 0 deg, gyro_scale 0.97")
