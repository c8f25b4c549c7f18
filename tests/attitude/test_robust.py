"""Robustness blocks (objectives.attitude.filters.robust) against closed forms and timing properties."""

from __future__ import annotations

import math

import numpy as np
import pytest

from objectives.attitude.filters.robust import (
    _acc_gate,
    _mag_dist_update,
    _rest_update,
    acc_lp_coefficients,
    acc_lp_state,
    acc_lp_step,
    lp_gain,
    mag_dist_coefficients,
    mag_dist_state,
    rest_coefficients,
    rest_state,
)
from objectives.attitude.quaternion import qmul, rotmat

DT = 0.01
FIELD = np.array([0.0, 20.0, -40.0])  # uT, north and down (dip ~63 deg), in an ENU-like z-up frame


def _run_mag(fields, gyr_norm, coef, state=None):
    s = mag_dist_state() if state is None else state
    gains = np.array([_mag_dist_update(s, coef, f[0], f[1], f[2], g) for f, g in zip(fields, gyr_norm)])
    return gains, s


def test_lp_gain_closed_form():
    assert lp_gain(2.0, 0.01) == pytest.approx(1 - math.exp(-0.005))
    assert lp_gain(0.0, 0.01) == 1.0
    with pytest.raises(ValueError, match="tau_s"):
        lp_gain(-1.0, 0.01)


def test_mag_first_field_accepted_after_new_first_time_of_rotation_then_learned():
    coef = mag_dist_coefficients(DT, new_first_time_s=5.0, new_min_gyr_dps=20.0)
    n = 1500
    fields = np.tile(FIELD, (n, 1))
    fast = np.full(n, math.radians(30.0))
    gains, s = _run_mag(fields, fast, coef)
    # rejected (gain 0) until 5 s of rotation have passed on a steady candidate (sample 0 starts it)
    first_ok = int(np.argmax(gains == 1.0))
    assert abs(first_ok * DT - 5.0) <= 2 * DT
    assert s[6] == 0.0
    assert s[0] == pytest.approx(np.linalg.norm(FIELD), rel=1e-9)
    assert s[1] == pytest.approx(math.asin(40 / np.linalg.norm(FIELD)), rel=1e-9)
    # without rotation the field is never accepted (the heading reference needs motion to be trusted)
    gains_slow, _ = _run_mag(fields, np.zeros(n), coef)
    assert (gains_slow < 1).all()


def test_mag_disturbance_rejected_then_softened_then_new_field_accepted():
    coef = mag_dist_coefficients(DT, max_rejection_s=3.0, rejection_factor=2.0, new_time_s=10.0,
                                 new_first_time_s=1.0, tau_current_s=0.0)
    calm = np.tile(FIELD, (300, 1))
    _, s = _run_mag(calm, np.full(300, 1.0), coef)
    assert s[6] == 0.0
    # a magnet: norm up 30 %: disturbed at once, gain 0 for max_rejection_s, then 1/factor
    dist = np.tile(1.3 * FIELD, (1200, 1))
    gains, s = _run_mag(dist, np.full(1200, 1.0), coef, s)
    assert gains[0] == 0.0
    n_zero = int(np.sum(gains == 0.0))
    assert abs(n_zero * DT - 3.0) <= 2 * DT
    # the disturbance stayed 10 s with rotation: accepted as the new field (1200 samples = 12 s)
    assert (gains == 1.0).any()
    i_new = int(np.argmax(gains == 1.0))
    assert abs(i_new * DT - 10.0) <= 2 * DT
    assert np.all(gains[n_zero:i_new] == 0.5) and np.all(gains[i_new:] == 1.0)
    assert s[0] == pytest.approx(1.3 * np.linalg.norm(FIELD), rel=1e-6)


def test_mag_dip_change_alone_is_a_disturbance_and_heading_is_not():
    coef = mag_dist_coefficients(DT, tau_current_s=0.0, dip_th_deg=10.0)
    _, s = _run_mag(np.tile(FIELD, (700, 1)), np.full(700, 1.0), coef)
    assert s[6] == 0.0
    # same norm, heading rotated by 90 deg about z: not a disturbance (heading errors are the filter's job)
    rot = np.array([FIELD[1], 0.0, FIELD[2]])
    g, s = _run_mag(np.tile(rot, (10, 1)), np.full(10, 1.0), coef, s)
    assert (g == 1.0).all()
    # same norm, dip 20 deg steeper: disturbed
    nrm, dip = np.linalg.norm(FIELD), math.asin(40 / np.linalg.norm(FIELD)) + math.radians(20)
    tilted = np.array([0.0, nrm * math.cos(dip), -nrm * math.sin(dip)])
    g, s = _run_mag(np.tile(tilted, (10, 1)), np.full(10, 1.0), coef, s)
    assert (g == 0.0).all() and s[6] == 1.0


def test_rest_detected_after_min_time_and_bias_converges():
    coef = rest_coefficients(DT, min_rest_s=1.5, tau_bias_s=1.0)
    bias = np.radians([0.5, -0.3, 0.2])
    rng = np.random.default_rng(0)
    s = rest_state()
    rest = []
    for _ in range(1000):
        g = bias + rng.normal(0, 0.002, 3)
        a = np.array([0.0, 0.0, 9.81]) + rng.normal(0, 0.02, 3)
        rest.append(_rest_update(s, coef, g[0], g[1], g[2], a[0], a[1], a[2]))
    rest = np.array(rest)
    # still from the first sample: rest from 1.5 s on
    assert not rest[:148].any() and rest[152:].all()
    assert np.allclose(s[8:11], bias, atol=np.radians(0.02))


def test_motion_is_not_rest_and_bias_is_clipped():
    coef = rest_coefficients(DT, bias_clip_dps=2.0)
    s = rest_state()
    t = np.arange(600) * DT
    for ti in t:  # rotation at 30 deg/s oscillating: deviation from the low-pass above 2 deg/s
        w = math.radians(30) * math.sin(2 * math.pi * ti)
        assert not _rest_update(s, coef, w, 0.0, 0.0, 0.0, 0.0, 9.81)
    # a constant rate larger than the clip is motion too, never bias
    s = rest_state()
    for _ in range(600):
        assert not _rest_update(s, coef, math.radians(5.0), 0.0, 0.0, 0.0, 0.0, 9.81)
    assert np.all(s[8:11] == 0.0)


def _angle_deg(v, u):
    return math.degrees(math.acos(np.clip(v @ u / (np.linalg.norm(v) * np.linalg.norm(u)), -1, 1)))


def test_acc_lowpass_in_earth_frame_ignores_zero_mean_translation():
    """Level sensor turning about up, translating back and forth: the earth-frame low-pass stays up."""
    coef = acc_lp_coefficients(DT, tau_acc_s=3.0)
    s0, s1, s2, n = acc_lp_state()
    worst_raw, worst_lp = 0.0, 0.0
    for i in range(3000):
        t = i * DT
        yaw = 0.5 * t
        q = np.array([math.cos(yaw / 2), 0.0, 0.0, math.sin(yaw / 2)])
        lin_e = np.array([8.0 * math.sin(2 * math.pi * 1.0 * t), 0.0, 0.0])  # 0.8 g at 1 Hz, earth x
        acc_s = rotmat(q).T @ (lin_e + np.array([0, 0, 9.81]))
        s0, s1, s2, n, ox, oy, oz = acc_lp_step(coef[0], s0, s1, s2, n, *q, *acc_s)
        out = np.array([ox, oy, oz])
        up_s = rotmat(q).T @ np.array([0, 0, 1.0])
        if t > 10:
            worst_raw = max(worst_raw, _angle_deg(acc_s, up_s))
            worst_lp = max(worst_lp, _angle_deg(out, up_s))
    # closed forms: raw tilt atan(8 / 9.81); a first-order low-pass attenuates the 1 Hz term by
    # 1 / sqrt(1 + (2 pi f tau)^2), so the residual tilt is atan(8 / 18.9 / 9.81) = 2.5 deg
    assert worst_raw == pytest.approx(math.degrees(math.atan(8 / 9.81)), rel=0.01)
    want = math.degrees(math.atan(8 / math.sqrt(1 + (2 * math.pi * 3.0) ** 2) / 9.81))
    assert worst_lp == pytest.approx(want, rel=0.05)


def test_acc_gate():
    coef = acc_lp_coefficients(DT, gate_norm=0.2, gate_angle_deg=20.0)
    q = np.array([1.0, 0, 0, 0])
    assert _acc_gate(coef, q, 0.0, 0.0, 9.81) == 1.0
    assert _acc_gate(coef, q, 0.0, 0.0, 9.81 * 1.3) == 0.0            # |a| - g too large
    tilt = math.radians(30)
    assert _acc_gate(coef, q, 9.81 * math.sin(tilt), 0.0, 9.81 * math.cos(tilt)) == 0.0  # 30 deg from prediction
    # the same vector is accepted when q predicts that tilt (about the y axis of the sensor)
    qt = np.array([math.cos(tilt / 2), 0.0, math.sin(tilt / 2), 0.0])
    a = rotmat(qt).T @ np.array([0, 0, 9.81])
    assert _acc_gate(coef, qt, a[0], a[1], a[2]) == 1.0
    assert _acc_gate(coef, q, 0.0, 0.0, 0.0) == 0.0
    assert qmul(q, q)[0] == 1.0


@pytest.mark.parametrize("fn, kw, msg", [
    (mag_dist_coefficients, {"norm_th": 0.0}, "norm_th"),
    (mag_dist_coefficients, {"rejection_factor": 0.5}, "rejection"),
    (rest_coefficients, {"min_rest_s": -1.0}, "min_rest_s"),
    (acc_lp_coefficients, {"gate_norm": float("nan")}, "gate_norm"),
])
def test_bad_parameters_named(fn, kw, msg):
    with pytest.raises(ValueError, match=msg):
        fn(DT, **kw)


def test_mag_detection_matches_vqf_sample_for_sample():
    """Independent reference: the vqf package's own magDistDetected on a level sensor turning at 30 deg/s
    about up through a 10 s magnet (norm x1.3), a return to the old field and a new field (dip +20 deg)
    that stays 40 s (accepted after magNewTime = 20 s). VQF's rest-bias and motion-bias estimation are
    off so its 6-D attitude is the gyro integral and its earth-frame field has our norm and dip."""
    vqf = pytest.importorskip("vqf")
    dt, w = 0.01, math.radians(30.0)
    t = np.arange(int(120 / dt)) * dt
    n = t.size
    nrm, dip = np.linalg.norm(FIELD), math.asin(40 / np.linalg.norm(FIELD))
    me = np.tile(FIELD, (n, 1))
    me[(t >= 30) & (t < 40)] *= 1.3
    d2 = dip + math.radians(20)
    me[t >= 80] = [0.0, nrm * math.cos(d2), -nrm * math.sin(d2)]
    c, s = np.cos(w * t), np.sin(w * t)
    ms = np.ascontiguousarray(np.stack([c * me[:, 0] + s * me[:, 1], -s * me[:, 0] + c * me[:, 1], me[:, 2]], 1))
    gyr = np.zeros((n, 3))
    gyr[:, 2] = w
    acc = np.ascontiguousarray(np.tile([0.0, 0.0, 9.81], (n, 1)))
    ref = vqf.VQF(dt, magCurrentTau=0.0, motionBiasEstEnabled=False, restBiasEstEnabled=False).updateBatch(
        gyr, acc, ms)["magDistDetected"].astype(bool)
    coef, st = mag_dist_coefficients(dt, tau_current_s=0.0), mag_dist_state()
    mine = np.empty(n, bool)
    for i in range(n):
        _mag_dist_update(st, coef, me[i, 0], me[i, 1], me[i, 2], w)
        mine[i] = st[6] != 0.0
    assert np.array_equal(mine, ref)
    # the scenario exercises every transition: first field (5 s), magnet on/off, new field accepted (~100 s)
    assert np.allclose(np.flatnonzero(np.diff(mine.astype(int))) * dt, [5.0, 29.99, 40.48, 79.99, 99.99])
