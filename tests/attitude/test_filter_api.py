"""The filters' public API: one parameter declaration per filter (defaults, space, validation,
describe), runs on plain arrays, per-sample streams equal to the batch run."""

from __future__ import annotations

import importlib.util
import json
import math
from pathlib import Path

import numpy as np
import pytest

from objectives.attitude.data.recording import Recording
from objectives.attitude.data.synthetic import simulate_imu
from objectives.attitude.filters import filter_names, get_filter
from objectives.attitude.filters.stream import BufferedStream, StateStream
from objectives.params import Interval, Param, ParamSet

HAVE_VQF = importlib.util.find_spec("vqf") is not None
NAMES = [n for n in filter_names() if n != "vqf" or HAVE_VQF]
BEFORE = json.loads((Path(__file__).resolve().parents[1] / "reference" / "declarations_before.json").read_text())
DT = 0.01


def _plain(v):
    if isinstance(v, float) and math.isinf(v):
        return "inf" if v > 0 else "-inf"
    if isinstance(v, dict):
        return {k: _plain(x) for k, x in v.items()}
    return v


@pytest.fixture(scope="module")
def rec():
    """A short 9-D recording with large tilts, heading changes and gyro bias (ENU)."""
    n = 160
    t = np.arange(n) * DT
    h = 0.5 * np.stack([0.6 * np.sin(1.7 * t), 0.4 * np.sin(1.1 * t + 1.0), 2.0 * np.sin(0.5 * t)], 1)
    c, s = np.cos(h), np.sin(h)
    q = np.stack([c[:, 0] * c[:, 1] * c[:, 2] + s[:, 0] * s[:, 1] * s[:, 2],
                  s[:, 0] * c[:, 1] * c[:, 2] - c[:, 0] * s[:, 1] * s[:, 2],
                  c[:, 0] * s[:, 1] * c[:, 2] + s[:, 0] * c[:, 1] * s[:, 2],
                  c[:, 0] * c[:, 1] * s[:, 2] - s[:, 0] * s[:, 1] * c[:, 2]], 1)
    return simulate_imu(q, DT, frame="ENU", rng=np.random.default_rng(3), gyr_noise=0.003, acc_noise=0.05,
                        mag_noise=0.002, gyr_bias=(0.01, -0.02, 0.015))


# --- one declaration -----------------------------------------------------------------------------
@pytest.mark.parametrize("name", [n for n in NAMES if n in BEFORE["filters"]])  # filters older than the declarations
def test_declaration_reproduces_previous_defaults_and_space(name):
    """Defaults and default search space equal those of the hand-written tuples and dicts they replace."""
    cls = get_filter(name)
    before = BEFORE["filters"][name]
    # every declared filter gained the common start option ``init`` (last, fixed at "auto") and the EKF family,
    # the QRAUKF, Madgwick and Mahony their robust blocks (appended, fixed, off); the rest is unchanged
    assert cls.defaults["init"] == "auto" and list(cls.defaults)[-1] == "init"
    added = {"init": "auto"}
    if name in ("ekf", "faekf", "qraukf"):
        added.update(acc_lp_tau_s=0.0, mag_rejection=False, mag_max_rejection_s=60.0, mag_norm_th=0.1,
                     mag_dip_th_deg=10.0, rest_bias=False, rest_bias_var=3e-6)
    if name in ("madgwick", "mahony"):  # their robust blocks (appended, fixed, off)
        added.update(acc_lp_tau_s=0.0, mag_rejection=False, mag_max_rejection_s=60.0, mag_norm_th=0.1,
                     mag_dip_th_deg=10.0, rest_bias=False, mag_ref_start=True, rest_bias_tau_s=2.0)
    if name in ("lcf", "ccf"):  # alpha_mode (per_sample: the seed's filter) and its time constant, fixed
        added.update(alpha_mode="per_sample", tau_s=0.1)
    if name == "ccf":  # the CCF's robust options (appended, fixed, off: the paper's filter)
        added.update(acc_lp_tau_s=0.0, mag_rejection=False, mag_max_rejection_s=60.0, mag_norm_th=0.1,
                     mag_dip_th_deg=10.0, mag_weight=1.0)
    assert {k: cls.defaults[k] for k in added} == added
    defaults = {k: v for k, v in cls.defaults.items() if k not in added}
    assert _plain(defaults) == before["defaults"]
    assert list(defaults) == list(before["defaults"]) or set(defaults) == set(before["defaults"])
    space = _plain(cls.space().to_dict())
    for k, v in added.items():
        assert space.pop(k)["fixed"] == v
    assert list(space) == list(before["space"])  # same order: same unit-cube encoding
    before_space = dict(before["space"])
    if name == "faekf":  # K1 is held at 1 since: only the products K_j rho matter (test_ekf.py)
        assert space.pop("K1")["fixed"] == 1.0 and before_space.pop("K1")["low"] == 1.0
    for key, old in before_space.items():
        for field, value in old.items():  # bounds, scale, integer, fixed value, unit and doc kept
            assert space[key][field] == value, (name, key, field)


@pytest.mark.parametrize("name", NAMES)
def test_describe_lists_every_parameter_with_unit(name):
    cls = get_filter(name)
    d = cls.describe()
    assert d["name"] == name and d["summary"]
    rows = {p["name"]: p for p in d["params"]}
    assert set(rows) == set(cls.defaults)
    for key, row in rows.items():
        assert row["default"] == cls.defaults[key] or (row["default"] != row["default"])
        assert set(row) >= {"name", "default", "bounds", "scale", "unit", "doc", "eq", "allowed"}
        assert row["doc"], (name, key)
        if row["kind"] == "number":
            assert row["unit"], (name, key)  # every number has a unit ("1" when dimensionless)
        if row["bounds"] is not None:
            assert row["scale"] in ("linear", "log")
            assert tuple(row["bounds"]) == (cls.space()[key].low, cls.space()[key].high)
    assert cls.declaration().markdown().count("\n") == len(rows) + 1


def _bad_values(p: Param):
    """Values outside what ``p`` allows, with a description."""
    if p.kind == "bool":
        return ["yes", 2]
    if p.kind == "choice":
        return ["no-such-option"]
    if p.kind != "number":
        return []
    out = [float("nan"), "1.0"]
    a: Interval = p.allowed
    if math.isfinite(a.low):
        out.append(a.low - 1.0 if not a.low_open else a.low)
    if math.isfinite(a.high):
        out.append(a.high + 1.0)
    if p.integer:
        out.append(20.5)
    return out


@pytest.mark.parametrize("name", NAMES)
def test_every_bad_value_names_filter_key_value_and_range(name):
    cls = get_filter(name)
    checked = 0
    for p in cls.declaration():
        for bad in _bad_values(p):
            with pytest.raises(ValueError) as exc:
                cls(**{p.name: bad})
            msg = str(exc.value)
            assert msg.startswith(f"{name}: {p.name} must be"), msg
            assert repr(bad) in msg, msg
            if p.kind == "number":
                assert str(p.allowed) in msg, msg
            checked += 1
    assert checked >= len(cls.defaults)
    with pytest.raises(ValueError, match=f"{name}: unknown parameter"):
        cls(no_such_parameter=1.0)


def test_validated_once_with_values_normalised():
    from objectives.attitude.filters.ekf import FAEKF
    from objectives.attitude.filters.madgwick import Madgwick

    m = Madgwick(beta=1)  # an int is a number: stored as the float the kernel gets
    assert m.values["beta"] == 1.0 and isinstance(m.values["beta"], float)
    f = FAEKF(window=100.0, fft_length=128)
    assert f.values["window"] == 100 and isinstance(f.values["window"], int)
    with pytest.raises(ValueError, match="fft_length .* must be >= window"):
        FAEKF(window=300, fft_length=256)


def test_paramset_rejects_inconsistent_declarations():
    with pytest.raises(ValueError, match="declared twice"):
        ParamSet("x", (Param("a", 1.0), Param("a", 2.0)))
    with pytest.raises(ValueError, match="a must be"):  # the default itself must be allowed
        Param("a", -1.0, allowed=Interval(0.0))
    with pytest.raises(ValueError, match="outside the allowed range"):
        Param("a", 1.0, (-1.0, 2.0), allowed=Interval(0.0))


# --- plain arrays --------------------------------------------------------------------------------
@pytest.mark.parametrize("name", NAMES)
@pytest.mark.slow
def test_run_on_arrays_equals_run_on_recording(name, rec):
    flt = get_filter(name)()
    want = flt.run(rec)
    got = flt.run(rec.gyr, rec.acc, rec.mag, rate_hz=1.0 / DT)
    np.testing.assert_array_equal(got, want)
    assert got.shape == (rec.n, 4)
    np.testing.assert_array_equal(flt.run(rec.gyr, rec.acc, mag=rec.mag, dt=DT), want)
    if name not in ("madgwick", "mahony", "lcf", "ncf", "ccf", "ekf", "faekf", "qukf", "qraukf", "vqf"):
        return
    ned = Recording("ned", rec.gyr, rec.acc, rec.mag, DT, frame="NED")  # same data, output frame NED
    np.testing.assert_array_equal(flt.run(rec.gyr, rec.acc, rec.mag, dt=DT, frame="NED"), flt.run(ned))


def test_run_on_arrays_errors(rec):
    from objectives.attitude.filters.madgwick import Madgwick

    m = Madgwick()
    with pytest.raises(ValueError, match="exactly one of rate_hz= .* or dt="):
        m.run(rec.gyr, rec.acc, rec.mag)
    with pytest.raises(ValueError, match="exactly one of"):
        m.run(rec.gyr, rec.acc, rec.mag, rate_hz=100.0, dt=0.01)
    with pytest.raises(ValueError, match="rate_hz must be a finite number > 0"):
        m.run(rec.gyr, rec.acc, rec.mag, rate_hz=0.0)
    with pytest.raises(ValueError, match="needs acc"):
        m.run(rec.gyr, rate_hz=100.0)
    with pytest.raises(ValueError, match="'acc'"):
        m.run(rec.gyr, rec.acc[:, :2], rec.mag, rate_hz=100.0)
    with pytest.raises(ValueError, match="'mag'"):
        m.run(rec.gyr, rec.acc, rec.mag[:-1], rate_hz=100.0)
    # mag=None is the IMU-only filter, as the README says (tests/attitude/test_data_checks.py for every kind)
    np.testing.assert_array_equal(m.run(rec.gyr, rec.acc, rate_hz=100.0),
                                  Madgwick(use_mag=False).run(rec.gyr, rec.acc, rate_hz=100.0))
    with pytest.raises(ValueError, match=r"takes no \['rate_hz'\]"):
        m.run(rec, rate_hz=100.0)


# --- streaming -----------------------------------------------------------------------------------
#: filters whose kernel carries its state: O(1) per sample
NATIVE = {"madgwick", "mahony", "lcf", "ncf", "ccf", "ekf", "kf1d", "mahony1d", "madgwick1d", "realtime", "qukf",
          "qraukf", "imu_tools_madgwick", "valenti"}


@pytest.mark.parametrize("name", NAMES)
@pytest.mark.slow
def test_stream_equals_batch_sample_by_sample(name, rec):
    flt = get_filter(name)()
    want = flt.run(rec)
    s = flt.stream(rate_hz=1.0 / DT)
    if name != "vqf":  # vqf streams through the package's own per-sample update
        assert isinstance(s, StateStream if name in NATIVE else BufferedStream)
    got = np.array([s.update(rec.gyr[k], rec.acc[k], rec.mag[k]) for k in range(rec.n)])
    np.testing.assert_array_equal(got, want)


@pytest.mark.parametrize("name", sorted(NATIVE - {"kf1d", "mahony1d", "madgwick1d", "qukf", "qraukf"}))  # UKFs: 9-D
@pytest.mark.slow
def test_native_stream_imu_only_and_explicit_start(name, rec):
    flt = get_filter(name)(use_mag=False, **({"gyro_sample": "current", "acc_gate": 0.5} if name == "ekf" else {}))
    q0 = np.array([0.9, 0.1, -0.2, 0.3]) / np.linalg.norm([0.9, 0.1, -0.2, 0.3])
    want = flt.run(rec.gyr, rec.acc, None, dt=DT, q0=q0, frame="NED")
    s = flt.stream(dt=DT, q0=q0, frame="NED")
    got = np.array([s.update(g, a) for g, a in zip(rec.gyr, rec.acc)])
    np.testing.assert_array_equal(got, want)


@pytest.mark.parametrize("name", ["akf1d", "faekf"])
def test_adaptive_stream_with_short_packets(name, rec):
    """Several fuzzy packets inside the recording: the packet measures are causal (held over the next
    packet), so the buffered stream equals the batch; FAEKF's eq. 27 with the magnetometer normalises
    by the median field norm of the whole recording in the batch, so there only the first packet agrees."""
    flt = get_filter(name)(window=16, fft_length=32, **({"use_mag": False} if name == "faekf" else {}))
    want = flt.run(rec)
    s = flt.stream(dt=DT)
    got = np.array([s.update(g, a, m) for g, a, m in zip(rec.gyr, rec.acc, rec.mag)])
    np.testing.assert_array_equal(got, want)
    if name == "faekf":
        flt = get_filter(name)(window=16, fft_length=32)
        want = flt.run(rec)
        s = flt.stream(dt=DT)
        got = np.array([s.update(g, a, m) for g, a, m in zip(rec.gyr, rec.acc, rec.mag)])
        np.testing.assert_array_equal(got[:16], want[:16])


@pytest.mark.parametrize("name, kw", [("kf1d", {"p0_theta": 1e-3, "p0_bias": 1e-6}),
                                      ("mahony1d", {"Ki": 0.004, "exact_step": False}),
                                      ("madgwick1d", {"beta": 0.05, "exact_step": False}),
                                      ("akf1d", {"window": 64, "fft_length": 64})])
def test_tilt_streams_on_the_tilt_bench(name, kw):
    """The 1-D filters on their own bench (NED, vibration and external acceleration), non-default options."""
    from objectives.attitude.data.synthetic import tilt1d

    bench = tilt1d(duration_s=0.5, rate_hz=800.0, seed=2, frame="NED")
    flt = get_filter(name)(**kw)
    want = flt.run(bench)
    s = flt.stream(dt=bench.dt, frame="NED")
    got = np.array([s.update(g, a) for g, a in zip(bench.gyr, bench.acc)])
    np.testing.assert_array_equal(got, want)


def test_stream_errors(rec):
    from objectives.attitude.filters.madgwick import Madgwick

    with pytest.raises(ValueError, match="exactly one of"):
        Madgwick().stream()
    with pytest.raises(ValueError, match="no truth"):
        Madgwick().stream(rate_hz=100.0, q0="truth")
    s = Madgwick().stream(rate_hz=100.0)
    s.update(rec.gyr[0], rec.acc[0], rec.mag[0])  # a first sample without mag makes it IMU-only (test_data_checks)
    with pytest.raises(ValueError, match="every update needs mag"):
        s.update(rec.gyr[1], rec.acc[1])
    with pytest.raises(ValueError, match=r"gyr as a \(3,\) sample"):
        s.update(rec.gyr[:2], rec.acc[1], rec.mag[1])


def test_readme_arrays_example(rec, capsys):
    """The README's plain-array example, run as written."""
    readme = (Path(__file__).resolve().parents[2] / "README.md").read_text()
    blocks = [b.split("```", 1)[0] for b in readme.split("```python\n")[1:]]
    code = next(b for b in blocks if "flt.stream(" in b)
    assert len(code.strip().splitlines()) <= 10
    ns = {"gyr": rec.gyr, "acc": rec.acc, "mag": rec.mag}
    exec(compile(code, "README.md", "exec"), ns)
    assert ns["q"].shape == (rec.n, 4)
    np.testing.assert_array_equal(ns["q_now"], ns["q"][-1])
    assert "beta 0.1 (0.001, 1.0) rad/s report eq. 33" in capsys.readouterr().out
