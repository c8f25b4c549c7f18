"""The combined rotation + translation proxy (benchmarks/broad_combined.py) against closed forms."""

from __future__ import annotations

import numpy as np
import pytest

from benchmarks.broad_combined import (
    combined_recording,
    gravity_check,
    linear_acc_earth,
    quarter_errors,
)
from objectives.attitude.data.recording import Recording
from objectives.attitude.quaternion import rotmat_batch

G = 9.81
DT = 0.01


def _tumbling(n: int, seed: int) -> np.ndarray:
    """Unit quaternions (n, 4) of a smooth tumbling motion (independent of the code under test)."""
    t = np.arange(n) * DT
    rng = np.random.default_rng(seed)
    a, b, c = rng.uniform(0.3, 1.5, 3)
    ang = np.stack([a * np.sin(0.7 * t), b * np.sin(1.1 * t + 0.3), c * t], axis=1)  # roll, pitch, yaw (rad)
    cr, sr = np.cos(ang[:, 0] / 2), np.sin(ang[:, 0] / 2)
    cp, sp = np.cos(ang[:, 1] / 2), np.sin(ang[:, 1] / 2)
    cy, sy = np.cos(ang[:, 2] / 2), np.sin(ang[:, 2] / 2)
    return np.stack([cy * cp * cr + sy * sp * sr, cy * cp * sr - sy * sp * cr,
                     sy * cp * sr + cy * sp * cr, sy * cp * cr - cy * sp * sr], axis=1)


def _rec(name: str, quat: np.ndarray, a_lin: np.ndarray, motion_from: int) -> Recording:
    """A recording whose accelerometer is exactly ``R^T (a_lin + g e_z)`` (specific force, ENU)."""
    n = quat.shape[0]
    R = rotmat_batch(quat)  # sensor-to-earth
    f_earth = a_lin + np.array([0.0, 0.0, G])
    acc = np.einsum("nji,nj->ni", R, f_earth)  # R^T f
    motion = np.arange(n) >= motion_from
    mag = np.einsum("nji,j->ni", R, np.array([0.0, 20.0, -40.0]))
    return Recording(name=name, gyr=np.zeros((n, 3)), acc=acc, mag=mag, dt=DT, quat=quat, motion=motion,
                     units={"gyr": "rad/s", "acc": "m/s^2", "mag": "uT"})


def _a_lin(n: int, seed: int) -> np.ndarray:
    t = np.arange(n) * DT
    rng = np.random.default_rng(seed)
    amp, w = rng.uniform(2.0, 15.0, 3), rng.uniform(2.0, 8.0, 3)
    return amp * np.sin(w * t[:, None])


def test_linear_acc_earth_recovers_the_linear_acceleration():
    n = 500
    a = _a_lin(n, 1)
    rec = _rec("trans", _tumbling(n, 2), a, 100)
    np.testing.assert_allclose(linear_acc_earth(rec, G), a, atol=1e-10)


def test_combined_accelerometer_is_gravity_plus_the_shifted_linear_acceleration():
    n_rot, n_trans, on_rot, on_trans = 600, 700, 50, 180
    q_rot = _tumbling(n_rot, 3)
    rot = _rec("rot", q_rot, np.zeros((n_rot, 3)), on_rot)
    a = _a_lin(n_trans, 4)
    trans = _rec("trans", _tumbling(n_trans, 5), a, on_trans)
    lost_q = np.array(trans.quat)
    lost_q[400:420] = np.nan  # markers lost: nothing known to add there
    trans = Recording(name="trans", gyr=trans.gyr, acc=trans.acc, mag=trans.mag, dt=DT, quat=lost_q,
                      motion=trans.motion)
    out = combined_recording(rot, trans, align="motion")
    shift = on_trans - on_rot
    n = min(n_rot, n_trans - shift)
    assert out.gyr.shape[0] == n and out.name == "rot+trans"
    expect = a[np.arange(n) + shift].copy()
    lost = (np.arange(n) + shift >= 400) & (np.arange(n) + shift < 420)
    expect[lost] = 0.0
    # in the rotation trial's earth frame the new specific force is gravity plus the translation's acceleration
    f_earth = np.einsum("nij,nj->ni", rotmat_batch(q_rot[:n]), out.acc)
    np.testing.assert_allclose(f_earth - [0.0, 0.0, G], expect, atol=1e-9)
    np.testing.assert_array_equal(out.gyr, rot.gyr[:n])
    np.testing.assert_array_equal(out.mag, rot.mag[:n])
    np.testing.assert_array_equal(out.quat, rot.quat[:n])
    np.testing.assert_allclose(out.extra["lin_acc_earth"], expect, atol=1e-9)


def test_gain_zero_and_start_alignment():
    rot = _rec("rot", _tumbling(300, 6), np.zeros((300, 3)), 10)
    trans = _rec("trans", _tumbling(250, 7), _a_lin(250, 8), 40)
    same = combined_recording(rot, trans, gain=0.0)
    np.testing.assert_allclose(same.acc, rot.acc[:same.acc.shape[0]], atol=1e-12)
    start = combined_recording(rot, trans, align="start")
    assert start.gyr.shape[0] == 250
    f_earth = np.einsum("nij,nj->ni", rotmat_batch(rot.quat[:250]), start.acc)
    np.testing.assert_allclose(f_earth[:, :2], _a_lin(250, 8)[:, :2], atol=1e-9)


def test_gravity_check_separates_the_right_convention_from_the_wrong_one():
    n = 400
    q = _tumbling(n, 9)
    noise = np.random.default_rng(0).normal(0.0, 0.05, (n, 3))
    a = np.zeros((n, 3))
    a[200:] = _a_lin(200, 10)
    rec = _rec("r", q, a, 200)
    rec = Recording(name="r", gyr=rec.gyr, acc=rec.acc + noise, mag=rec.mag, dt=DT, quat=q, motion=rec.motion)
    assert gravity_check(rec, G) < 0.15
    conj = q * np.array([1.0, -1.0, -1.0, -1.0])  # earth-to-sensor read as sensor-to-earth
    wrong = Recording(name="w", gyr=rec.gyr, acc=rec.acc, mag=rec.mag, dt=DT, quat=conj, motion=rec.motion)
    assert gravity_check(wrong, G) > 1.0


def test_bad_inputs_name_the_problem():
    rot = _rec("rot", _tumbling(100, 1), np.zeros((100, 3)), 10)
    other = Recording(name="x", gyr=rot.gyr, acc=rot.acc, mag=rot.mag, dt=0.02, quat=rot.quat, motion=rot.motion)
    with pytest.raises(ValueError, match="sampling times differ"):
        combined_recording(rot, other)
    with pytest.raises(ValueError, match="align"):
        combined_recording(rot, rot, align="middle")
    still = Recording(name="s", gyr=rot.gyr, acc=rot.acc, mag=rot.mag, dt=DT, quat=rot.quat, motion=np.zeros(100, bool))
    with pytest.raises(ValueError, match="no motion sample"):
        combined_recording(rot, still)


def test_quarter_errors_see_an_error_that_grows():
    n = 800
    q = _tumbling(n, 11)
    rec = _rec("r", q, np.zeros((n, 3)), 0)
    ang = np.linspace(0.0, np.radians(20.0), n)  # heading error growing linearly to 20 deg
    err = np.stack([np.cos(ang / 2), 0 * ang, 0 * ang, np.sin(ang / 2)], axis=1)
    from objectives.attitude.quaternion import qmul_batch

    e = quarter_errors(qmul_batch(err, q), rec)
    assert e["q1"] < e["q2"] < e["q3"] < e["q4"]
    assert e["heading"] == pytest.approx(e["total"], rel=1e-6) and e["incl"] < 1e-6
    assert e["total"] == pytest.approx(np.degrees(np.sqrt(np.mean(ang ** 2))), rel=1e-6)


def test_broad_conventions_hold_at_rest(broad_dir):
    from objectives.attitude.data.broad import load_broad

    rec = load_broad(broad_dir / "15_undisturbed_fast_translation_A.mat")
    assert gravity_check(rec) < 0.3  # noise and truth tilt error; the wrong sign would give 2 g
