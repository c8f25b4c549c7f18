"""Earth-frame conversions, rotation matrices (eq. 3), Euler angles (eq. 6) and TRIAD (eqs. 11-14).

Earth frames
------------
``ENU`` (x east, y north, z up) and ``NED`` (x north, y east, z down). A sensor-to-earth quaternion
in one frame converts to the other by left-multiplying the constant frame rotation
``Q_NED_FROM_ENU`` (or its conjugate): ``q_ned = Q_NED_FROM_ENU * q_enu``.
``NWU`` (x north, y west, z up, the frame of Madgwick's and Mahony's reference code) converts to ENU
by ``Q_ENU_FROM_NWU = (1/sqrt2, 0, 0, 1/sqrt2)``, the rotation BROAD's example code applies.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from objectives.attitude.quaternion.algebra import _as_rows, qconj_batch, qmul_batch

__all__ = [
    "Q_ENU_FROM_NWU", "Q_NED_FROM_ENU", "frame_rotation", "to_frame",
    "FRAME_CODES", "rotmat", "rotmat_batch", "qeuler_zyx", "euler_zyx", "quat_from_euler_zyx",
    "triad", "triad_code", "triad_batch",
]

_S = 1.0 / math.sqrt(2.0)
#: sensor-to-earth quaternion in NWU -> ENU (rotation of 90 deg about up).
Q_ENU_FROM_NWU = np.array([_S, 0.0, 0.0, _S])
#: ENU -> NED: x_ned = y_enu, y_ned = x_enu, z_ned = -z_enu (rotation of 180 deg about (1,1,0)/sqrt2).
Q_NED_FROM_ENU = np.array([0.0, _S, _S, 0.0])


def frame_rotation(src: str, dst: str) -> np.ndarray:
    """Constant quaternion ``r`` with ``q_dst = r * q_src`` for sensor-to-earth quaternions."""
    src, dst = src.upper(), dst.upper()
    table = {
        ("ENU", "ENU"): np.array([1.0, 0, 0, 0]),
        ("NED", "NED"): np.array([1.0, 0, 0, 0]),
        ("NWU", "NWU"): np.array([1.0, 0, 0, 0]),
        ("ENU", "NED"): Q_NED_FROM_ENU,
        ("NED", "ENU"): qconj_batch(Q_NED_FROM_ENU),
        ("NWU", "ENU"): Q_ENU_FROM_NWU,
        ("ENU", "NWU"): qconj_batch(Q_ENU_FROM_NWU),
    }
    if (src, dst) not in table:
        via = qmul_batch(frame_rotation("ENU", dst), frame_rotation(src, "ENU"))[0]
        return via
    return np.asarray(table[(src, dst)], dtype=float)


def to_frame(q: np.ndarray, src: str, dst: str) -> np.ndarray:
    """Convert sensor-to-earth quaternions ``q`` (N, 4) or (4,) from earth frame ``src`` to ``dst``."""
    q = np.asarray(q, dtype=float)
    if src.upper() == dst.upper():
        return q.copy()
    out = qmul_batch(frame_rotation(src, dst), np.ascontiguousarray(q))
    return out[0] if q.ndim == 1 else out


#: integer codes of the earth frames inside kernels (``FRAME_CODES["NED"]``).
FRAME_CODES = {"ENU": 0, "NED": 1, "NWU": 2}
# cos(pitch) below which euler_zyx treats the attitude as gimbal-locked: there the generic
# formulas lose ~1e-16/cos(pitch) rad, the locked branch ~cos(pitch) rad; 1e-8 balances both.
_GIMBAL_LOCK = 1e-8


def _frame_code(frame: str) -> int:
    try:
        return FRAME_CODES[str(frame).upper()]
    except KeyError:
        raise ValueError(f"frame must be one of {sorted(FRAME_CODES)}, got {frame!r}") from None


@njit(cache=True)
def rotmat(q):
    """Rotation matrix of the quaternion ``q``: the FAEKF paper eq. 3.

    Parameters
    ----------
    q : ndarray (4,)
        Unit quaternion ``(w, x, y, z)``, sensor-to-earth.

    Returns
    -------
    ndarray (3, 3)
        ``R`` with ``v_earth = R @ v_sensor`` (the paper's :math:`{}^E R(q)`). The formula uses
        ``w^2 + x^2 - y^2 - z^2`` on the diagonal, as printed, so ``q`` must be of unit norm.
    """
    w, x, y, z = q[0], q[1], q[2], q[3]
    R = np.empty((3, 3))
    R[0, 0] = w * w + x * x - y * y - z * z
    R[0, 1] = 2.0 * (x * y - w * z)
    R[0, 2] = 2.0 * (x * z + w * y)
    R[1, 0] = 2.0 * (x * y + w * z)
    R[1, 1] = w * w - x * x + y * y - z * z
    R[1, 2] = 2.0 * (y * z - w * x)
    R[2, 0] = 2.0 * (x * z - w * y)
    R[2, 1] = 2.0 * (y * z + w * x)
    R[2, 2] = w * w - x * x - y * y + z * z
    return R


def rotmat_batch(q: np.ndarray) -> np.ndarray:
    """Rotation matrices (eq. 3) of (N, 4) quaternions: (N, 3, 3); a (4,) input gives (3, 3)."""
    q2, single = _as_rows(q, 4, "rotmat_batch: q")
    w, x, y, z = q2.T
    R = np.empty((q2.shape[0], 3, 3))
    R[:, 0, 0] = w * w + x * x - y * y - z * z
    R[:, 0, 1] = 2.0 * (x * y - w * z)
    R[:, 0, 2] = 2.0 * (x * z + w * y)
    R[:, 1, 0] = 2.0 * (x * y + w * z)
    R[:, 1, 1] = w * w - x * x + y * y - z * z
    R[:, 1, 2] = 2.0 * (y * z - w * x)
    R[:, 2, 0] = 2.0 * (x * z - w * y)
    R[:, 2, 1] = 2.0 * (y * z + w * x)
    R[:, 2, 2] = w * w - x * x - y * y + z * z
    return R[0] if single else R


@njit(cache=True, inline="always")
def _euler_into(w, x, y, z, out, i):
    # Elements of R (eq. 3) written homogeneously (scale-invariant in q).
    r11 = w * w + x * x - y * y - z * z
    r21 = 2.0 * (x * y + w * z)
    r31 = 2.0 * (x * z - w * y)
    r32 = 2.0 * (y * z + w * x)
    r33 = w * w - x * x - y * y + z * z
    cp = math.sqrt(r11 * r11 + r21 * r21)  # cos(pitch) times |q|^2
    out[i, 1] = math.atan2(-r31, cp)
    if not (cp <= _GIMBAL_LOCK * (w * w + x * x + y * y + z * z)):  # NaN takes this branch
        out[i, 0] = math.atan2(r32, r33)
        out[i, 2] = math.atan2(r21, r11)
    else:
        # |pitch| = pi/2: only roll -+ yaw is defined; report yaw = 0 and put it all in roll
        r12 = 2.0 * (x * y - w * z)
        r22 = w * w - x * x + y * y - z * z
        out[i, 0] = math.atan2(-r12 if r31 > 0.0 else r12, r22)
        out[i, 2] = 0.0


@njit(cache=True)
def qeuler_zyx(q):
    """Scalar kernel of :func:`euler_zyx`: (4,) -> (3,) roll, pitch, yaw in rad."""
    out = np.empty((1, 3))
    _euler_into(q[0], q[1], q[2], q[3], out, 0)
    return out[0]


@njit(cache=True)
def _euler_kernel(q, out):
    for i in range(q.shape[0]):
        _euler_into(q[i, 0], q[i, 1], q[i, 2], q[i, 3], out, i)


def euler_zyx(q: np.ndarray) -> np.ndarray:
    """Roll, pitch, yaw (rad) of sensor-to-earth quaternions: intrinsic Z-Y'-X'' (the FAEKF paper eq. 6).

    The angles satisfy ``R(q) = Rz(yaw) @ Ry(pitch) @ Rx(roll)`` with ``R`` the sensor-to-earth
    matrix of eq. 3: starting from the earth axes, turn by yaw about z, then by pitch about the new
    y, then by roll about the newest x. Roll is about the sensor x axis, pitch about y, yaw about z.

    The formulas hold in any right-handed earth frame; what the angles mean depends on it:

    - ``NED`` (the FAEKF paper): yaw is the heading, clockwise seen from above, from north to the
      projection of the sensor x axis (0 = x points north, +pi/2 = east); pitch > 0 lifts the
      nose (x up); roll > 0 lowers the right side (y down). The usual aerospace angles for a
      forward-right-down sensor.
    - ``ENU`` (BROAD): yaw is counter-clockwise seen from above, from east to the projection of x
      (0 = x points east, +pi/2 = north), so heading-from-north = pi/2 - yaw; pitch > 0 lowers x
      (nose down); roll > 0 lifts y.

    The same physical orientation has different Euler angles in NED and ENU (the earth axes
    differ, the sensor axes do not): convert quaternions with :func:`to_frame` first, never the
    angles.

    Eq. 6 as printed, ``phi = atan2(2 q2 q3 - 2 q0 q1, 2 q0^2 + 2 q3^2 - 1)`` etc., is this
    function applied to ``conj(q)``: the paper writes it for the earth-to-sensor quaternion (as in
    Madgwick's report). We keep ``q`` sensor-to-earth everywhere and use the equivalent
    ``roll = atan2(R32, R33)``, ``pitch = -asin(R31)``, ``yaw = atan2(R21, R11)``. Pitch is
    computed as ``atan2(-R31, hypot(R11, R21))`` (the same angle, accurate near +-pi/2 and free of
    the ``sqrt(1 - x^2)`` of eq. 6 going NaN when rounding pushes ``|x|`` above 1); the formulas
    are homogeneous, so ``q`` need not be exactly normalised.

    Gimbal lock: at ``|pitch| = pi/2`` roll and yaw are not unique (only their difference or sum
    is); when ``cos(pitch) < 1e-8`` the function reports ``yaw = 0`` and the whole turn about the
    vertical in roll, so :func:`quat_from_euler_zyx` still inverts it. Errors between Euler angles
    near the lock are meaningless; compare quaternions there.

    Parameters
    ----------
    q : ndarray (N, 4) or (4,)
        Quaternions ``(w, x, y, z)``, sensor-to-earth.

    Returns
    -------
    ndarray (N, 3) or (3,)
        Columns roll in ``[-pi, pi]``, pitch in ``[-pi/2, pi/2]``, yaw in ``[-pi, pi]``, rad.
        Non-finite input rows give NaN rows.
    """
    q2, single = _as_rows(q, 4, "euler_zyx: q")
    out = np.empty((q2.shape[0], 3))
    _euler_kernel(q2, out)
    return out[0] if single else out


@njit(cache=True)
def _euler_error_kernel(q_est, q_true, out):
    """``wrap(euler(q_true) - euler(q_est))`` per row into ``out`` (N, 3), in one pass.

    Truth rows with a non-finite value give NaN; otherwise estimate rows that are non-finite or
    zero give ``pi``. Used by :func:`objectives.attitude.metrics.euler_errors`.
    """
    two_pi = 2.0 * math.pi
    for i in range(q_true.shape[0]):
        tw, tx, ty, tz = q_true[i, 0], q_true[i, 1], q_true[i, 2], q_true[i, 3]
        if not (math.isfinite(tw) and math.isfinite(tx) and math.isfinite(ty) and math.isfinite(tz)):
            out[i, 0] = math.nan
            out[i, 1] = math.nan
            out[i, 2] = math.nan
            continue
        ew, ex, ey, ez = q_est[i, 0], q_est[i, 1], q_est[i, 2], q_est[i, 3]
        ok = math.isfinite(ew) and math.isfinite(ex) and math.isfinite(ey) and math.isfinite(ez)
        if not ok or (ew == 0.0 and ex == 0.0 and ey == 0.0 and ez == 0.0):
            out[i, 0] = math.pi
            out[i, 1] = math.pi
            out[i, 2] = math.pi
            continue
        _euler_into(tw, tx, ty, tz, out, i)
        a0, a1, a2 = out[i, 0], out[i, 1], out[i, 2]
        _euler_into(ew, ex, ey, ez, out, i)
        for k, a in ((0, a0), (1, a1), (2, a2)):
            d = a - out[i, k]  # in (-2 pi, 2 pi)
            if d >= math.pi:
                d -= two_pi
            elif d < -math.pi:
                d += two_pi
            out[i, k] = d


@njit(cache=True)
def _quat_from_euler_kernel(e, out):
    for i in range(e.shape[0]):
        cr, sr = math.cos(0.5 * e[i, 0]), math.sin(0.5 * e[i, 0])
        cp, sp = math.cos(0.5 * e[i, 1]), math.sin(0.5 * e[i, 1])
        cy, sy = math.cos(0.5 * e[i, 2]), math.sin(0.5 * e[i, 2])
        # products in the order yaw, pitch, roll (q = qz qy qx, FAEKF paper eqs. 4-6): the synthetic
        # benches build their truth with this kernel and their recorded digests depend on the rounding
        out[i, 0] = cy * cp * cr + sy * sp * sr
        out[i, 1] = cy * cp * sr - sy * sp * cr
        out[i, 2] = cy * sp * cr + sy * cp * sr
        out[i, 3] = sy * cp * cr - cy * sp * sr


def quat_from_euler_zyx(euler: np.ndarray) -> np.ndarray:
    """Sensor-to-earth quaternion ``qz(yaw) * qy(pitch) * qx(roll)``: the inverse of :func:`euler_zyx`.

    Parameters
    ----------
    euler : ndarray (N, 3) or (3,)
        Roll, pitch, yaw in rad (any range).

    Returns
    -------
    ndarray (N, 4) or (4,)
        Unit quaternions ``(w, x, y, z)``; not sign-normalised (``w`` may be negative).
    """
    e2, single = _as_rows(euler, 3, "quat_from_euler_zyx: euler")
    out = np.empty((e2.shape[0], 4))
    _quat_from_euler_kernel(e2, out)
    return out[0] if single else out


@njit(cache=True, inline="always")
def _triad_into(ax, ay, az, mx, my, mz, code, out, i):
    """TRIAD (eqs. 11-14) for one sample, written into ``out[i]``; NaN if acc x mag vanishes."""
    # r1 = A/|A|, r2 = A x H / |A x H|, r3 = r1 x r2 (eq. 12)
    na = math.sqrt(ax * ax + ay * ay + az * az)
    cx = ay * mz - az * my
    cy = az * mx - ax * mz
    cz = ax * my - ay * mx
    nc = math.sqrt(cx * cx + cy * cy + cz * cz)
    if not (na > 0.0 and nc > 1e-12 * na * math.sqrt(mx * mx + my * my + mz * mz)) or not (nc < math.inf):
        out[i, 0] = math.nan
        out[i, 1] = math.nan
        out[i, 2] = math.nan
        out[i, 3] = math.nan
        return
    r1x, r1y, r1z = ax / na, ay / na, az / na
    r2x, r2y, r2z = cx / nc, cy / nc, cz / nc
    r3x = r1y * r2z - r1z * r2y
    r3y = r1z * r2x - r1x * r2z
    r3z = r1x * r2y - r1y * r2x
    # Earth triad (eq. 11) from s1 = up, s2 = up x north / |.| = west, s3 = s1 x s2 = south,
    # written out per frame: (s1, s2, s3) as earth-frame vectors.
    if code == 1:  # NED: up = -z, west = -y, south = -x
        # R = M_ref M_mea^T (sensor-to-earth); row k of R is sum_j s_j[k] * r_j
        R00, R01, R02 = -r3x, -r3y, -r3z
        R10, R11, R12 = -r2x, -r2y, -r2z
        R20, R21, R22 = -r1x, -r1y, -r1z
    elif code == 0:  # ENU: up = z, west = -x, south = -y
        R00, R01, R02 = -r2x, -r2y, -r2z
        R10, R11, R12 = -r3x, -r3y, -r3z
        R20, R21, R22 = r1x, r1y, r1z
    else:  # NWU: up = z, west = y, south = -x
        R00, R01, R02 = -r3x, -r3y, -r3z
        R10, R11, R12 = r2x, r2y, r2z
        R20, R21, R22 = r1x, r1y, r1z
    # Eq. 14 with the numerically safe branches (Shepperd): divide by the largest of 4 w^2,
    # 4 x^2, 4 y^2, 4 z^2 instead of 4 q0, which is near 0 for rotations near 180 deg.
    tr = R00 + R11 + R22
    if tr > 0.0:
        s = 2.0 * math.sqrt(1.0 + tr)  # = 4 q0
        w = 0.25 * s
        x = (R21 - R12) / s
        y = (R02 - R20) / s
        z = (R10 - R01) / s
    elif R00 > R11 and R00 > R22:
        s = 2.0 * math.sqrt(max(1.0 + R00 - R11 - R22, 0.0))  # = 4 |q1|
        w = (R21 - R12) / s
        x = 0.25 * s
        y = (R01 + R10) / s
        z = (R02 + R20) / s
    elif R11 > R22:
        s = 2.0 * math.sqrt(max(1.0 + R11 - R00 - R22, 0.0))
        w = (R02 - R20) / s
        x = (R01 + R10) / s
        y = 0.25 * s
        z = (R12 + R21) / s
    else:
        s = 2.0 * math.sqrt(max(1.0 + R22 - R00 - R11, 0.0))
        w = (R10 - R01) / s
        x = (R02 + R20) / s
        y = (R12 + R21) / s
        z = 0.25 * s
    n = math.sqrt(w * w + x * x + y * y + z * z)
    if w < 0.0:
        n = -n
    out[i, 0] = w / n
    out[i, 1] = x / n
    out[i, 2] = y / n
    out[i, 3] = z / n


@njit
def triad_code(acc, mag, code):
    """:func:`triad` with the earth frame as an integer code (``FRAME_CODES``): 0 ENU, 1 NED, 2 NWU."""
    out = np.empty((1, 4))
    _triad_into(acc[0], acc[1], acc[2], mag[0], mag[1], mag[2], code, out, 0)
    return out[0]


@njit(cache=True)
def triad(acc, mag, frame="NED"):
    """Sensor-to-earth quaternion from one accelerometer and magnetometer sample: TRIAD, FAEKF eqs. 11-14.

    Parameters
    ----------
    acc : ndarray (3,)
        Specific force in the sensor frame, any unit (at rest it points *up*, the project's
        convention; see :mod:`objectives.attitude.data.recording`).
    mag : ndarray (3,)
        Magnetic field in the sensor frame, any unit; magnetic north is taken as earth north.
    frame : {"NED", "ENU", "NWU"}
        Earth frame of the result. Inside other kernels prefer :func:`triad_code` (no string).

    Returns
    -------
    ndarray (4,)
        Unit quaternion ``(w, x, y, z)`` with ``w >= 0``; NaN if ``acc`` is zero or parallel to
        ``mag`` (heading undefined), or if an input is not finite.

    Notes
    -----
    Sensor triad (eq. 12): ``r1 = A/|A|``, ``r2 = A x H/|A x H|``, ``r3 = r1 x r2``. Earth triad
    (eq. 11) from the same construction on the earth-frame references. The paper uses the
    gravity vector ``g = (0, 0, 9.81)`` NED with an accelerometer that reads it (pointing down);
    our accelerometer reads the specific force (pointing up), so both triads use *up* instead
    (``s1 = up``, ``s2 = up x north / |.| = west``, ``s3 = s1 x s2 = south``): flipping both
    ``r1`` and ``s1`` flips ``r2, s2`` too and gives the same rotation. Only the direction of
    north in the earth frame enters (the magnetic inclination cancels in ``s2``), so no field
    model is needed. Eq. 13 builds ``S_R = M_mea M_ref^T`` (earth-to-sensor); eq. 14 read on it
    gives ``q1 = (r23 - r32) / 4 q0`` etc., which is exactly the quaternion of the sensor-to-earth
    matrix ``E_R = M_ref M_mea^T`` in our convention, so the result is sensor-to-earth as
    everywhere in the project. Eq. 14 divides by ``4 q0``, which loses all precision for
    rotations near 180 deg (``q0 -> 0``); we use Shepperd's branch choice (divide by the
    largest of the four ``4 |q_i|``), identical to eq. 14 whenever ``1 + trace > 1``.
    """
    f = frame.upper()
    code = 1
    if f == "ENU":
        code = 0
    elif f == "NWU":
        code = 2
    elif f != "NED":
        raise ValueError("triad: frame must be 'NED', 'ENU' or 'NWU'")
    return triad_code(acc, mag, code)


@njit(cache=True)
def _triad_kernel(acc, mag, code, out):
    for i in range(acc.shape[0]):
        _triad_into(acc[i, 0], acc[i, 1], acc[i, 2], mag[i, 0], mag[i, 1], mag[i, 2], code, out, i)


def triad_batch(acc: np.ndarray, mag: np.ndarray, frame: str = "NED") -> np.ndarray:
    """:func:`triad` for every row: acc (N, 3), mag (N, 3) -> (N, 4) sensor-to-earth quaternions.

    Rows where TRIAD is undefined (zero acc, acc parallel to mag, non-finite input) are NaN.
    A single (3,) pair gives a (4,) result.
    """
    a2, single = _as_rows(acc, 3, "triad_batch: acc")
    m2, _ = _as_rows(mag, 3, "triad_batch: mag")
    if a2.shape[0] != m2.shape[0]:
        raise ValueError(f"triad_batch: acc has {a2.shape[0]} rows, mag has {m2.shape[0]}")
    out = np.empty((a2.shape[0], 4))
    _triad_kernel(a2, m2, _frame_code(frame), out)
    return out[0] if single else out
