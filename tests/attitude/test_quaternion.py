"""Quaternion kernels: algebraic identities (hypothesis), references, frame meaning, TRIAD."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from objectives.attitude import quaternion as Q
from tests.reference import attitude_core_reference as ref

finite = st.floats(-1.0, 1.0, allow_nan=False, allow_infinity=False)
quat4 = st.tuples(finite, finite, finite, finite).filter(lambda t: sum(x * x for x in t) > 1e-3)
vec3 = st.tuples(*(st.floats(-50.0, 50.0, allow_nan=False) for _ in range(3)))
FAST = settings(max_examples=150, deadline=None)


def unit(t) -> np.ndarray:
    q = np.array(t, float)
    return q / np.linalg.norm(q)


def same_rotation(p, q, atol=1e-12):
    return min(np.abs(p - q).max(), np.abs(p + q).max()) < atol


def random_quats(n, seed=0):
    q = np.random.default_rng(seed).normal(size=(n, 4))
    return q / np.linalg.norm(q, axis=1, keepdims=True)


# --- identities ---------------------------------------------------------------------------------

@FAST
@given(quat4, vec3)
def test_rotation_preserves_norm(qt, v):
    v = np.array(v)
    np.testing.assert_allclose(np.linalg.norm(Q.qrot(unit(qt), v)), np.linalg.norm(v), rtol=1e-12, atol=1e-12)


@FAST
@given(quat4)
def test_q_times_conj_is_identity(qt):
    q = unit(qt)
    np.testing.assert_allclose(Q.qmul(q, Q.qconj(q)), [1, 0, 0, 0], atol=1e-15)
    np.testing.assert_allclose(Q.qmul(Q.qconj(q), q), [1, 0, 0, 0], atol=1e-15)


@FAST
@given(quat4)
def test_exp_of_log_is_identity(qt):
    q = unit(qt)
    q = q if q[0] >= 0 else -q
    v = Q.qlog(q)
    assert np.linalg.norm(v) <= math.pi + 1e-12
    np.testing.assert_allclose(Q.qexp(v), q, atol=1e-12)


@FAST
@given(st.tuples(*(st.floats(-1.8, 1.8, allow_nan=False) for _ in range(3))))
def test_log_of_exp_is_identity(vt):
    v = np.array(vt)  # |v| < pi
    np.testing.assert_allclose(Q.qlog(Q.qexp(v)), v, atol=1e-12)


@FAST
@given(st.floats(-math.pi, math.pi), st.floats(-1.5, 1.5), st.floats(-math.pi, math.pi))
def test_euler_round_trip_away_from_gimbal_lock(roll, pitch, yaw):
    e = np.array([roll, pitch, yaw])  # |pitch| <= 86 deg
    back = Q.euler_zyx(Q.quat_from_euler_zyx(e))
    np.testing.assert_allclose(np.angle(np.exp(1j * (back - e))), 0.0, atol=1e-9)


@FAST
@given(quat4)
def test_quat_from_euler_inverts_euler(qt):
    q = unit(qt)
    assert same_rotation(Q.quat_from_euler_zyx(Q.euler_zyx(q)), q, atol=2e-8)


@FAST
@given(quat4, quat4, vec3)
def test_product_composes_rotations(pt, qt, v):
    p, q, v = unit(pt), unit(qt), np.array(v)
    np.testing.assert_allclose(Q.qrot(Q.qmul(p, q), v), Q.qrot(p, Q.qrot(q, v)), atol=1e-11)


@FAST
@given(quat4, quat4)
def test_the_scalar_kernels_product_is_the_hamilton_product(pt, qt):
    """``_scalar.qmul``, the one product the realtime, Valenti and UKF kernels inline, on any two quaternions
    (not only unit ones) against the reference's matrix form, and on the basis (i j = k, j i = -k)."""
    from objectives.attitude.filters._scalar import qmul

    p, q = np.array(pt), np.array(qt)
    np.testing.assert_allclose(qmul(*p, *q), ref.hamilton(p, q), rtol=0, atol=1e-15)
    assert qmul(0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0) == (0.0, 0.0, 0.0, 1.0)
    assert qmul(0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 0.0, 0.0) == (0.0, 0.0, 0.0, -1.0)


# --- against references ---------------------------------------------------------------------------

def test_rotmat_is_the_sandwich_product_and_orthonormal():
    for q in random_quats(20):
        R = Q.rotmat(q)
        np.testing.assert_allclose(R, ref.matrix(q), atol=1e-14)
        np.testing.assert_allclose(R @ R.T, np.eye(3), atol=1e-14)
        assert abs(np.linalg.det(R) - 1) < 1e-13
    qs = random_quats(7, seed=3)
    np.testing.assert_allclose(Q.rotmat_batch(qs), np.stack([ref.matrix(q) for q in qs]), atol=1e-14)


def test_euler_matches_composition_of_elementary_rotations_and_scipy():
    qs = random_quats(50, seed=1)
    e = Q.euler_zyx(qs)
    for q, (r, p, y) in zip(qs, e):
        np.testing.assert_allclose(ref.matrix_from_euler(r, p, y), ref.matrix(q), atol=1e-12)
    sp = Rotation.from_quat(qs[:, [1, 2, 3, 0]]).as_euler("ZYX")[:, ::-1]
    np.testing.assert_allclose(e, sp, atol=1e-12)
    assert np.all(np.abs(e[:, 1]) <= math.pi / 2)


def test_euler_is_paper_eq6_applied_to_the_conjugate():
    for q in random_quats(30, seed=2):
        np.testing.assert_allclose(Q.euler_zyx(q), ref.euler_eq6(ref.conj(q)), atol=1e-12)
        np.testing.assert_allclose(Q.qeuler_zyx(q), Q.euler_zyx(q), atol=0)


def test_euler_is_scale_invariant_and_nan_propagates():
    q = random_quats(3, seed=4)
    np.testing.assert_allclose(Q.euler_zyx(3.7 * q), Q.euler_zyx(q), atol=1e-13)
    assert np.isnan(Q.euler_zyx(np.array([np.nan, 0, 0, 1.0]))).all()
    # pitch exactly at the pole stays finite (eq. 6's sqrt(1 - x^2) would divide by 0)
    qp = Q.quat_from_euler_zyx([0.3, math.pi / 2, 0.0])
    assert abs(Q.euler_zyx(qp)[1] - math.pi / 2) < 1e-7


def test_exp_log_small_angles_and_batches():
    v = np.array([1e-10, -2e-10, 3e-11])
    q = Q.qexp(v)
    np.testing.assert_allclose(q[1:], v / 2, rtol=1e-12)
    np.testing.assert_allclose(Q.qlog(q), v, rtol=1e-12)
    np.testing.assert_allclose(Q.qlog(-q), v, rtol=1e-12)  # -q is the same rotation
    np.testing.assert_allclose(Q.qexp(np.zeros(3)), [1, 0, 0, 0])
    vs = np.random.default_rng(5).normal(size=(9, 3))
    sp = Rotation.from_rotvec(vs).as_quat()[:, [3, 0, 1, 2]]
    assert all(same_rotation(a, b, atol=1e-13) for a, b in zip(Q.qexp_batch(vs), sp))
    qs = random_quats(9, seed=6)
    sp_vec = Rotation.from_quat(qs[:, [1, 2, 3, 0]]).as_rotvec()
    np.testing.assert_allclose(Q.qlog_batch(qs), sp_vec, atol=1e-12)
    assert Q.qexp_batch(vs[0]).shape == (4,) and Q.qlog_batch(qs[0]).shape == (3,)


def test_wrappers_reject_bad_shapes():
    with pytest.raises(ValueError, match="euler_zyx"):
        Q.euler_zyx(np.zeros((3, 3)))
    with pytest.raises(ValueError, match="qexp_batch"):
        Q.qexp_batch(np.zeros((2, 4)))
    with pytest.raises(ValueError, match="rows"):
        Q.triad_batch(np.ones((3, 3)), np.ones((2, 3)))
    with pytest.raises(ValueError, match="frame"):
        Q.triad_batch(np.ones((2, 3)), np.ones((2, 3)), frame="XYZ")


# --- frame meaning ------------------------------------------------------------------------------

def test_yaw_meaning_in_ned_and_enu():
    # NED: sensor x pointing east is heading +90 deg (clockwise from north).
    q = Q.quat_from_euler_zyx([0.0, 0.0, math.pi / 2])
    np.testing.assert_allclose(Q.qrot(q, np.array([1.0, 0, 0])), [0, 1, 0], atol=1e-15)  # NED east = y
    # ENU: the same quaternion puts x on earth y = north: yaw is counter-clockwise from east.
    # The same physical orientation (x east, z down) in ENU: x -> (1,0,0), y (right) -> south, z -> down.
    R_enu = np.column_stack([[1.0, 0, 0], [0, -1.0, 0], [0, 0, -1.0]])
    q_enu = Q.to_frame(Q.quat_from_euler_zyx([0.0, 0.0, math.pi / 2]), "NED", "ENU")
    np.testing.assert_allclose(Q.rotmat(q_enu), R_enu, atol=1e-15)
    e_enu = Q.euler_zyx(q_enu)  # roll +-pi (z down in ENU), pitch 0, yaw 0: x east
    np.testing.assert_allclose([abs(e_enu[0]), e_enu[1], e_enu[2]], [math.pi, 0, 0], atol=1e-12)
    # nose up is positive pitch in NED (x gets a negative down component)
    qn = Q.quat_from_euler_zyx([0.0, 0.2, 0.0])
    assert Q.qrot(qn, np.array([1.0, 0, 0]))[2] < 0


# --- TRIAD --------------------------------------------------------------------------------------

EARTH = {  # up and north in each earth frame
    "NED": (np.array([0, 0, -1.0]), np.array([1.0, 0, 0])),
    "ENU": (np.array([0, 0, 1.0]), np.array([0, 1.0, 0])),
    "NWU": (np.array([0, 0, 1.0]), np.array([1.0, 0, 0])),
}


def synth(q, frame, incl_deg=64.0, field=48.0, g=9.81):
    up, north = EARTH[frame]
    h = field * (math.cos(math.radians(incl_deg)) * north - math.sin(math.radians(incl_deg)) * up)
    R = Q.rotmat_batch(q)
    return np.einsum("nji,j->ni", R, g * up), np.einsum("nji,j->ni", R, h)  # R^T v


@pytest.mark.parametrize("frame", ["NED", "ENU", "NWU"])
@pytest.mark.slow
def test_triad_recovers_truth_on_noise_free_data(frame):
    q = random_quats(200, seed=7)
    q *= np.sign(q[:, :1])
    acc, mag = synth(q, frame)
    out = Q.triad_batch(acc, mag, frame)
    np.testing.assert_allclose(out, q, atol=2e-15 * 50)
    for i in range(5):
        np.testing.assert_allclose(Q.triad(acc[i], mag[i], frame), out[i], atol=0)
    # inclination and magnitudes do not enter
    acc2, mag2 = synth(q, frame, incl_deg=-20.0, field=0.3, g=1.0)
    np.testing.assert_allclose(Q.triad_batch(acc2, mag2, frame), q, atol=1e-13)


def test_triad_safe_branch_near_180_degrees():
    # rotations of pi - 1e-9 rad: q0 ~ 5e-10, where eq. 14 divided by 4 q0 loses all digits
    axes = np.random.default_rng(8).normal(size=(50, 3))
    axes /= np.linalg.norm(axes, axis=1, keepdims=True)
    q = Q.qexp_batch(axes * (math.pi - 1e-9))
    acc, mag = synth(q, "NED")
    out = Q.triad_batch(acc, mag, "NED")
    assert np.all(out[:, 0] >= 0)
    assert all(same_rotation(o, t, atol=1e-12) for o, t in zip(out, q))
    # exactly 180 deg about x, y, z
    for ax in np.eye(3):
        qq = np.r_[0.0, ax][None]
        a, m = synth(qq, "ENU")
        assert same_rotation(Q.triad_batch(a, m, "ENU")[0], qq[0])


def test_triad_matches_paper_equations_literally():
    q = random_quats(100, seed=9)
    q *= np.sign(q[:, :1])
    q = q[q[:, 0] > 0.3]
    acc, mag = synth(q, "NED", incl_deg=63.0)
    for a, m, t in zip(acc, mag, q):
        np.testing.assert_allclose(Q.triad(a, m, "NED"), ref.triad_paper_ned(a, m), atol=1e-12)
        np.testing.assert_allclose(ref.triad_paper_ned(a, m), t, atol=1e-12)


def test_triad_frames_agree_with_to_frame_and_degenerate_input_is_nan():
    q = random_quats(20, seed=10)
    acc, mag = synth(q, "ENU")
    enu = Q.triad_batch(acc, mag, "ENU")
    ned = Q.triad_batch(acc, mag, "NED")
    for a, b in zip(Q.to_frame(enu, "ENU", "NED"), ned):
        assert same_rotation(a, b, atol=1e-13)
    bad = Q.triad_batch(np.array([[0, 0, 0.0], [0, 0, 9.8], [np.nan, 0, 1]]),
                        np.array([[1, 0, 0.0], [0, 0, 40.0], [1, 0, 0]]), "ENU")
    assert np.isnan(bad).all()


# ------------------------------------------------------------------------------------------------
# batch helpers the synthetic benches build on (one library for the whole project)
# ------------------------------------------------------------------------------------------------
def _rand_unit(rng, n):
    q = rng.standard_normal((n, 4))
    return q / np.linalg.norm(q, axis=1, keepdims=True)


def test_qrot_batch_is_the_sandwich_product_and_its_inverse():
    rng = np.random.default_rng(11)
    q, v = _rand_unit(rng, 50), rng.standard_normal((50, 3))
    fwd = Q.qrot_batch(q, v)
    np.testing.assert_allclose(fwd, Rotation.from_quat(q[:, [1, 2, 3, 0]]).apply(v), atol=1e-14)
    np.testing.assert_allclose(Q.qrot_batch(q, fwd, inverse=True), v, atol=1e-13)
    for i in range(5):  # the batch is the scalar kernel row by row, bit for bit
        np.testing.assert_array_equal(fwd[i], Q.qrot(q[i], v[i]))
        np.testing.assert_array_equal(Q.qrot_batch(q, v, inverse=True)[i], Q.qrot(Q.qconj(q[i]), v[i]))
    np.testing.assert_array_equal(Q.qrot_batch(q, v[0]), np.stack([Q.qrot(a, v[0]) for a in q]))
    assert Q.qrot_batch(q[0], v[0]).shape == (3,)
    with pytest.raises(ValueError, match="qrot_batch: q has 50 rows, v has 2"):
        Q.qrot_batch(q, v[:2])


def test_qmul_batch_broadcasts_one_row_and_rejects_mismatched_rows():
    rng = np.random.default_rng(12)
    p, q = _rand_unit(rng, 20), _rand_unit(rng, 20)
    np.testing.assert_array_equal(Q.qmul_batch(p, q), np.stack([Q.qmul(a, b) for a, b in zip(p, q)]))
    np.testing.assert_array_equal(Q.qmul_batch(p[3], q), np.stack([Q.qmul(p[3], b) for b in q]))
    np.testing.assert_array_equal(Q.qmul_batch(p[:, ::1][::2], q[::2]), Q.qmul_batch(p, q)[::2])  # strided input
    with pytest.raises(ValueError, match="qmul_batch: p has 20 rows, q has 3"):
        Q.qmul_batch(p, q[:3])


def test_qlog_batch_agrees_with_the_scalar_kernel_to_one_ulp_of_the_angle():
    rng = np.random.default_rng(13)
    axes = rng.standard_normal((2000, 3))
    v = axes / np.linalg.norm(axes, axis=1, keepdims=True) * 10.0 ** rng.uniform(-12, math.log10(3.1), (2000, 1))
    q = Q.qexp_batch(v)
    q[::3] *= -1.0  # -q is the same rotation
    batch = Q.qlog_batch(q)
    scalar = np.stack([Q.qlog(r) for r in q])
    np.testing.assert_allclose(batch, scalar, rtol=4e-16, atol=0)
    np.testing.assert_allclose(batch, v, rtol=1e-12, atol=1e-20)
    assert np.isnan(Q.qlog_batch(np.array([1.0, np.nan, 0.0, 0.0]))).all()


def test_make_continuous_flips_sign_jumps_only():
    rng = np.random.default_rng(14)
    smooth = Q.qexp_batch(np.cumsum(rng.standard_normal((200, 3)) * 0.05, axis=0))
    flipped = smooth * np.where(rng.random(200) < 0.3, -1.0, 1.0)[:, None]
    flipped[0] = smooth[0]
    np.testing.assert_array_equal(Q.make_continuous(flipped), smooth)
    assert np.all(np.einsum("ij,ij->i", Q.make_continuous(flipped)[1:], smooth[:-1]) > 0)
    with pytest.raises(ValueError, match="make_continuous"):
        Q.make_continuous(np.zeros((3, 3)))


def test_quat_from_euler_zyx_is_the_product_of_elementary_rotations():
    rng = np.random.default_rng(15)
    e = rng.uniform(-4, 4, (300, 3))

    def axis(k, a):
        out = np.zeros((len(a), 4))
        out[:, 0], out[:, 1 + k] = np.cos(a / 2), np.sin(a / 2)
        return out

    composed = Q.qmul_batch(Q.qmul_batch(axis(2, e[:, 2]), axis(1, e[:, 1])), axis(0, e[:, 0]))
    np.testing.assert_allclose(Q.quat_from_euler_zyx(e), composed, atol=1e-15)
