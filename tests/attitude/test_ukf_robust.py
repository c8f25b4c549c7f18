"""QRAUKF robust blocks (objectives.attitude.filters.ukf.robust): off = the paper's filter bit for bit;
on, each block does its job on a recording built to need it."""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

import numpy as np
import pytest

from objectives.attitude.data.bench6dof import bench6dof
from objectives.attitude.filters import get_filter
from objectives.attitude.filters.robust import acc_lp_coefficients, mag_dist_coefficients, rest_coefficients
from objectives.attitude.filters.ukf.kernel import new_state, new_work, ukf_chunk
from objectives.attitude.filters.ukf.robust import ukf_robust_run
from objectives.attitude.fused_errors import error_sums
from tests.attitude.robust_cases import rest_recording

QRAUKF = get_filter("qraukf")
#: recorded rows (provenance in the file's "about"): every STEP-th sample, quaternion then bias
_RECORDED = json.loads(Path(__file__).with_name("ukf_recorded.json").read_text())
RECORDED, STEP = _RECORDED["rows"], _RECORDED["step"]


def _digest(res) -> str:
    return hashlib.sha256(np.ascontiguousarray(res.quat).tobytes()
                          + np.ascontiguousarray(res.diagnostics["bias"]).tobytes()).hexdigest()


@pytest.mark.parametrize("name", sorted(RECORDED))
def test_blocks_off_is_the_recorded_paper_filter(name):
    """Every 100th sample of the defaults' run equals the one recorded with the kernel of commit c7e2d30
    (tests/attitude/ukf_recorded.json; those arrays matched that commit's SHA-256 digests) to 1e-9 rad: the
    kernels since then differ in rounding only (vectorised sigma-point passes, reciprocal Cholesky)."""
    res = get_filter(name)().run_detailed(bench6dof(duration_s=5, seed=7), "accmag")
    rows = np.array(RECORDED[name])
    q, b = res.quat[::STEP], res.diagnostics["bias"][::STEP]
    assert q.shape[0] == rows.shape[0] == 50
    r = rows[:, :4]  # angle of q * conj(r) from its vector part (arccos of the dot quantises near 1)
    w = np.sum(q * r, axis=1)
    v = -q[:, :1] * r[:, 1:] + r[:, :1] * q[:, 1:] - np.cross(q[:, 1:], r[:, 1:])
    ang = 2 * np.arctan2(np.linalg.norm(v, axis=1), np.abs(w))
    assert np.max(ang) < 1e-9
    assert np.max(np.abs(b - rows[:, 4:])) < 1e-10
    assert np.max(np.abs(rows[-1, 4:])) > 1e-4  # the bias has moved: the comparison is not of the start


def test_blocks_off_with_other_thresholds_equals_the_kernel_bit_for_bit():
    rec = bench6dof(duration_s=3, seed=2, frame="ENU")
    off = QRAUKF(mag_norm_th=0.3, mag_dip_th_deg=3.0, mag_max_rejection_s=5.0, rest_bias_var=1e-3)
    res = off.run_detailed(rec, "truth")
    assert "mag_gain" not in res.diagnostics and _digest(res) == _digest(QRAUKF().run_detailed(rec, "truth"))


def _kernel_inputs(rec):
    f = QRAUKF()
    v = f.values
    coef = np.array([rec.dt, v["sigma_gyr"], v["att_rw"], v["bias_rw"], v["sigma_acc"], v["sigma_mag"],
                     v["n_sigma"]])
    arrays = [np.ascontiguousarray(a, dtype=np.float64) for a in (rec.gyr, rec.acc, rec.mag)]
    return arrays, coef, v


@pytest.mark.slow
def test_per_sample_driver_with_every_block_off_equals_one_kernel_call():
    rec = bench6dof(duration_s=2, seed=4, frame="ENU")
    (gyr, acc, mag), coef, v = _kernel_inputs(rec)
    q0 = rec.quat[0] / np.linalg.norm(rec.quat[0])
    ref = ukf_chunk(gyr, acc, mag, coef, True, *new_state(q0, v["p0_att"], v["p0_bias"], v["window"]))
    out = ukf_robust_run(gyr, acc, mag, coef, True, *new_state(q0, v["p0_att"], v["p0_bias"], v["window"]),
                         new_work(), np.zeros(4), mag_dist_coefficients(rec.dt), rest_coefficients(rec.dt),
                         acc_lp_coefficients(rec.dt))
    for key in ("quat", "bias", "lam", "skipped", "fallback"):
        assert np.array_equal(out[key], ref[key]), key
    assert np.all(out["mag_gain"] == 1.0) and not out["rest"].any()


def test_stream_with_every_block_on_equals_the_batch_sample_by_sample():
    """The O(1) stream carries the kernel's float and integer states and the blocks' states: equal to the
    batch run at every sample, on a recording where every block acts (rejection, rest, low-pass)."""
    rec = bench6dof(20.0, 100.0, 3, vibration=False, ext_acc_max_g=0.5, mag_pert_range=(0.1, 0.5))
    flt = QRAUKF(window=12, acc_lp_tau_s=3.0, mag_rejection=True, rest_bias=True)
    res = flt.run_detailed(rec)
    d = res.diagnostics
    assert (d["mag_gain"] < 0.5).any() and d["rest"].any()  # the blocks are not idle
    s = flt.stream(dt=rec.dt, frame=rec.frame)
    got = np.array([s.update(g, a, m) for g, a, m in zip(rec.gyr, rec.acc, rec.mag)])
    np.testing.assert_array_equal(got, res.quat)


def test_acc_low_pass_holds_inclination_through_oscillating_translation():
    def shake(t):  # 5 m/s^2 at 1 Hz along x for 20 s: velocity returns to zero every period
        a = np.zeros((t.size, 3))
        m = (t > 20) & (t < 40)
        a[m, 0] = 5.0 * np.sin(2 * np.pi * t[m])
        return a

    rec = rest_recording(6000, lin=shake)
    raw = error_sums(QRAUKF().run(rec, q0="truth"), rec.quat).broad_rmse_deg
    lp = error_sums(QRAUKF(acc_lp_tau_s=3.0).run(rec, q0="truth"), rec.quat).broad_rmse_deg
    assert lp[2] < 0.6 * raw[2]  # inclination (measured: 1.00 -> 0.41 deg)


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_magnetic_rejection_detects_the_disturbed_phases_and_holds_the_heading(seed):
    rec = bench6dof(duration_s=60, seed=seed, noise=False, vibration=False, external_acc=False)
    disturbed = np.linalg.norm(rec.extra["mag_disturbance"], axis=1) > 0.05
    res = QRAUKF(mag_rejection=True).run_detailed(rec, "truth")
    gain = res.diagnostics["mag_gain"]
    assert gain[disturbed].mean() < 0.15 and gain[~disturbed].mean() > 0.95
    plain = error_sums(QRAUKF().run(rec, q0="truth"), rec.quat, disturbed).broad_rmse_deg[1]
    held = error_sums(res.quat, rec.quat, disturbed).broad_rmse_deg[1]
    assert held < plain  # heading error inside the disturbances (measured e.g. 0.099 -> 0.003 deg, seed 3)


def test_rest_bias_flags_rest_and_speeds_up_the_bias_estimate():
    truth = np.array([0.01, -0.02, 0.03])
    rec = rest_recording(1000, bias=truth)
    plain = QRAUKF().run_detailed(rec, "truth").diagnostics
    res = QRAUKF(rest_bias=True).run_detailed(rec, "truth").diagnostics
    rest = res["rest"]
    assert not rest[:100].any() and rest[200:].all()  # min_rest_s = 1.5 s at 100 Hz, then at rest throughout
    err = np.abs(res["bias"][200] - truth).max()
    assert err < 0.6 * np.abs(plain["bias"][200] - truth).max()  # measured 0.0007 -> 0.0003 rad/s at 2 s


def test_robust_options_are_validated():
    with pytest.raises(ValueError, match="acc_lp_tau_s"):
        QRAUKF(acc_lp_tau_s=-1.0)
    with pytest.raises(ValueError, match="mag_rejection"):
        QRAUKF(mag_rejection="yes")
    assert "acc_lp_tau_s" not in get_filter("qukf").defaults  # the QUKF stays the paper's filter
