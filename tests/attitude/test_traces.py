"""Heading and inclination error (objectives.attitude.traces) against closed forms, and the order of the
report's recordings (worst first)."""

from types import SimpleNamespace

import numpy as np
import pytest

from objectives.attitude.quaternion import qmul_batch
from objectives.attitude.traces import error_angles_deg, recording_score, traces_doc, worst_first


def _axis_angle(axis, angle):
    axis = np.asarray(axis, float) / np.linalg.norm(axis, axis=-1, keepdims=True)
    return np.column_stack([np.cos(angle / 2), axis * np.sin(angle / 2)[:, None]])


def _rot(q):
    w, x, y, z = q.T
    return np.stack([np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)], -1),
                     np.stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)], -1),
                     np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], -1)], -2)


def test_heading_then_tilt_gives_back_both_angles():
    """q_est = Rz(h) * tilt(b about a horizontal axis) * q_true: heading error |h|, inclination error b."""
    rng = np.random.default_rng(0)
    n = 500
    h = rng.uniform(-np.pi + 1e-3, np.pi - 1e-3, n)
    b = rng.uniform(0, np.pi - 1e-3, n)
    phi = rng.uniform(0, 2 * np.pi, n)
    q_true = rng.normal(size=(n, 4))
    q_true /= np.linalg.norm(q_true, axis=1, keepdims=True)
    heading = _axis_angle(np.tile([0.0, 0.0, 1.0], (n, 1)), h)
    tilt = _axis_angle(np.column_stack([np.cos(phi), np.sin(phi), np.zeros(n)]), b)
    q_est = qmul_batch(qmul_batch(heading, tilt), q_true)
    head, incl = error_angles_deg(q_est, q_true)
    np.testing.assert_allclose(head, np.degrees(np.abs(h)), atol=1e-7)
    np.testing.assert_allclose(incl, np.degrees(b), atol=1e-6)


def test_inclination_is_the_angle_between_the_verticals():
    """Inclination error = angle between the estimated and the true vertical seen from the sensor."""
    rng = np.random.default_rng(1)
    q_est, q_true = rng.normal(size=(300, 4)), rng.normal(size=(300, 4))
    q_est /= np.linalg.norm(q_est, axis=1, keepdims=True)
    q_true /= np.linalg.norm(q_true, axis=1, keepdims=True)
    v_est = np.einsum("nji,j->ni", _rot(q_est), [0.0, 0.0, 1.0])  # R^T e_z: the vertical in the sensor frame
    v_true = np.einsum("nji,j->ni", _rot(q_true), [0.0, 0.0, 1.0])
    angle = np.degrees(np.arccos(np.clip(np.sum(v_est * v_true, axis=1), -1, 1)))
    _, incl = error_angles_deg(q_est, q_true)
    np.testing.assert_allclose(incl, angle, atol=1e-5)


def test_a_pure_heading_error_past_180_deg_does_not_wrap():
    h = np.radians(np.array([170.0, 179.0, 181.0, 190.0]))
    q_true = np.tile([1.0, 0.0, 0.0, 0.0], (4, 1))
    head, incl = error_angles_deg(_axis_angle(np.tile([0, 0, 1.0], (4, 1)), h), q_true)
    np.testing.assert_allclose(head, [170.0, 179.0, 179.0, 170.0], atol=1e-9)  # the shorter way round
    np.testing.assert_allclose(incl, 0.0, atol=1e-6)


def test_worst_first_by_the_metric_of_the_run():
    m = [("train", "a", {"total_rmse_deg": 1.0, "roll_rmse_deg": 9, "pitch_rmse_deg": 9, "yaw_rmse_deg": 9}),
         ("train", "b", {"total_rmse_deg": 3.0, "roll_rmse_deg": 1, "pitch_rmse_deg": 1, "yaw_rmse_deg": 1}),
         ("test", "c", {}),
         ("test", "d", {"total_rmse_deg": 2.0, "roll_rmse_deg": 2, "pitch_rmse_deg": 2, "yaw_rmse_deg": 2})]
    assert worst_first(m, "broad_mean_rmse") == [1, 3, 0, 2]
    assert worst_first(m, "euler_rmse_mean") == [0, 3, 1, 2]
    assert recording_score({"mse_1d": 0.5}, "mse_1d") == (0.5, "MSE (rad^2)")


def test_traces_doc_opens_on_the_worst_recording():
    t = np.linspace(0, 10, 4001)
    q = np.tile([1.0, 0.0, 0.0, 0.0], (len(t), 1))
    tilt = _axis_angle(np.tile([1.0, 0, 0], (len(t), 1)), np.radians(np.full(len(t), 5.0)))

    def item(name, est, score):
        rec = SimpleNamespace(name=name, time=t, quat=q, n=len(t))
        return ("test", rec, SimpleNamespace(quat=est), {"total_rmse_deg": score})

    doc = traces_doc([item("good", q, 0.1), item("bad", tilt, 5.0)], "broad_mean_rmse", ["errors_bad.png"])
    assert [it["name"] for it in doc["items"]] == ["bad", "good"] and "worst, bad" in doc["note"]
    bad = doc["items"][0]
    assert len(bad["x"]) <= 1500 and bad["label"] == "test: bad (total RMSE (deg) 5)"
    panels = {p["title"]: p for p in bad["panels"]}
    assert set(panels) == {"roll", "pitch", "yaw", "heading error", "inclination error"}
    assert panels["inclination error"]["series"][0]["y"][5] == pytest.approx(5.0, abs=1e-3)
    assert panels["heading error"]["series"][0]["y"][5] == pytest.approx(0.0, abs=1e-3)
    assert doc["replaces"] == ["errors_bad.png"]
