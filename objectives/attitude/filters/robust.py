"""Robustness building blocks for filter kernels: magnetic disturbances, rest and gyro bias, fast translation.

Real recordings (BROAD, Laidig et al. 2021) break filters tuned on clean data in three ways: a magnet
near the path turns the heading, a gyro bias of up to 0.5 deg/s makes the heading drift, and fast
translations make the accelerometer point anywhere but up. VQF (D. Laidig, T. Seel, "VQF: Highly
accurate IMU orientation estimation with bias estimation and magnetic disturbance rejection",
Information Fusion 91:187-204, 2023; "VQF" below) handles all three; these blocks take its ideas
(physical, rate-independent time constants; a reference field learned while undisturbed; low-pass
filtering in an almost-inertial frame) into small numba functions any kernel can call per sample.

Every block is a set of private ``@njit(cache=True)`` functions over a state array (float64, updated
in place) and a coefficient array (float64, made once by a public validating ``*_coefficients``
function from physical parameters and the sampling time). Nothing allocates per sample.

Gain of a first-order low-pass with time constant ``tau`` at sampling time ``dt`` (VQF eq. 8)::

    k(tau, dt) = 1 - exp(-dt / tau)

(a) Magnetic disturbance detection and rejection (VQF section 3.4)
-----------------------------------------------------------------
Input per sample: the magnetometer in an inclination-corrected earth frame (z up; e.g. rotated with
the filter's current attitude; heading errors do not matter) and the norm of the low-passed gyro.
From it ``norm = |m|`` and ``dip = -asin(m_z / |m|)`` (rad), low-passed with ``tau_current_s``.
The field is *undisturbed* when ``|norm - norm_ref| < norm_th * norm_ref`` and
``|dip - dip_ref| < dip_th``; after ``min_undisturbed_s`` of that the reference follows the field with
``k(tau_ref_s)``. A *candidate* field is tracked the same way; when it has been steady for
``new_time_s`` of rotation faster than ``new_min_gyr`` (``new_first_time_s`` while there is no
reference yet), it becomes the new reference (a magnet that stays, or a new room). The magnetometer
gain factor returned is ``1`` undisturbed, ``0`` while disturbed for at most ``max_rejection_s``
(rejection time, reduced by ``rejection_factor * dt`` per undisturbed sample), and
``1 / rejection_factor`` after that, so a long disturbance cannot freeze the heading for ever.

(b) Rest detection and gyro bias at rest (VQF section 3.3)
---------------------------------------------------------
Gyro and accelerometer are low-passed with ``tau_rest_s``; the sample is *still* when the squared
deviation of the raw signal from its low-pass is below ``th_gyr**2`` and ``th_acc**2`` and the
low-passed gyro is below ``bias_clip`` in every axis; *rest* is declared after ``min_rest_s`` of
still samples. At rest the bias estimate follows the low-passed gyro with ``k(tau_bias_s)`` and is
clipped to ``+-bias_clip``. (VQF uses second-order Butterworth low-passes and a Kalman filter for the
bias, also during motion; a first-order low-pass and a fixed time constant keep this block small.)

(c) Acceleration rejection through fast translation (VQF section 3.2 and a gate)
-------------------------------------------------------------------------------
Over a translation that starts and ends at rest the linear acceleration integrates to zero, so its
low-pass in an (almost) inertial frame vanishes while gravity stays: the accelerometer rotated into
the earth frame with the current attitude and low-passed with ``tau_acc_s`` points up even while the
raw vector does not. :func:`acc_lp_step` keeps that low-pass and returns it rotated back into the
sensor frame (a drop-in replacement for the measured acc of any kernel). :func:`_acc_gate` gives a
weight in [0, 1] for an accelerometer update: 0 when ``||a| - g| > gate_norm * g`` or when the angle
between ``a`` and the gyro-predicted gravity direction exceeds ``gate_angle``, else 1.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

__all__ = [
    "lp_gain", "mag_dist_coefficients", "mag_dist_state", "rest_coefficients", "rest_state",
    "acc_lp_coefficients", "acc_lp_state", "acc_lp_step", "MAG_STATE", "REST_STATE", "ACC_STATE", "MAG_COEF",
    "REST_COEF", "ACC_COEF",
]

# --- layouts --------------------------------------------------------------------------------------
#: magnetic state: ref_norm, ref_dip, undisturbed_t, cand_norm, cand_dip, cand_t, disturbed, reject_t,
#: lp_norm, lp_dip, lp_n (samples seen by the low-pass)
MAG_STATE = 11
#: rest state: gyr_lp[3], acc_lp[3], still_t, rest, bias[3], n (samples seen)
REST_STATE = 12
#: acc state: acc_lp_earth[3], n (samples seen)
ACC_STATE = 4
#: lengths of the blocks' coefficient arrays (:func:`mag_dist_coefficients`, :func:`rest_coefficients`,
#: :func:`acc_lp_coefficients`)
MAG_COEF = 11
REST_COEF = 7
ACC_COEF = 4


def lp_gain(tau_s: float, dt_s: float) -> float:
    """``1 - exp(-dt/tau)`` (VQF eq. 8); ``tau_s = 0`` gives 1 (no filtering)."""
    if not (math.isfinite(tau_s) and tau_s >= 0 and math.isfinite(dt_s) and dt_s > 0):
        raise ValueError(f"robust: need tau_s >= 0 and dt_s > 0, got tau_s={tau_s!r}, dt_s={dt_s!r}")
    return 1.0 if tau_s == 0 else 1.0 - math.exp(-dt_s / tau_s)


def _check_positive(where: str, **values: float) -> None:
    for k, v in values.items():
        if not (math.isfinite(v) and v > 0):
            raise ValueError(f"{where}: {k} must be a finite number > 0, got {v!r}")


# --- (a) magnetic disturbance -----------------------------------------------------------------------
def mag_dist_coefficients(dt_s: float, norm_th: float = 0.1, dip_th_deg: float = 10.0, tau_ref_s: float = 20.0,
                          tau_current_s: float = 0.05, min_undisturbed_s: float = 0.5, new_time_s: float = 20.0,
                          new_first_time_s: float = 5.0, new_min_gyr_dps: float = 20.0,
                          max_rejection_s: float = 60.0, rejection_factor: float = 2.0) -> np.ndarray:
    """Coefficients (11,) of the magnetic block; defaults are VQF's (``magNormTh`` ... ``magRejectionFactor``).

    Raises ``ValueError`` naming a parameter that is not a positive finite number
    (``rejection_factor`` must be >= 1, ``tau_current_s`` may be 0).
    """
    _check_positive("mag_dist", dt_s=dt_s, norm_th=norm_th, dip_th_deg=dip_th_deg, tau_ref_s=tau_ref_s,
                    min_undisturbed_s=min_undisturbed_s, new_time_s=new_time_s, new_first_time_s=new_first_time_s,
                    new_min_gyr_dps=new_min_gyr_dps, max_rejection_s=max_rejection_s)
    if not (math.isfinite(rejection_factor) and rejection_factor >= 1):
        raise ValueError(f"mag_dist: rejection_factor must be >= 1, got {rejection_factor!r}")
    return np.array([dt_s, norm_th, math.radians(dip_th_deg), lp_gain(tau_ref_s, dt_s),
                     lp_gain(tau_current_s, dt_s), min_undisturbed_s, new_time_s, new_first_time_s,
                     math.radians(new_min_gyr_dps), max_rejection_s, rejection_factor], dtype=np.float64)


def mag_dist_state() -> np.ndarray:
    """Initial magnetic state: no reference yet (disturbed until a field is accepted)."""
    s = np.zeros(MAG_STATE)
    s[3] = -1.0  # candidate norm: none
    s[6] = 1.0
    return s


@njit
def _mag_dist_update(state, coef, mx, my, mz, gyr_lp_norm):
    """One magnetometer sample in an inclination-corrected earth frame (z up); returns the gain factor.

    ``state`` (MAG_STATE,) is updated in place; ``coef`` from :func:`mag_dist_coefficients`;
    ``gyr_lp_norm`` rad/s. Returns 1 (undisturbed), 0 (rejecting) or 1/rejection_factor (rejected
    for longer than max_rejection_s). A zero vector changes nothing and returns 1.
    """
    dt, norm_th, dip_th, k_ref, k_cur = coef[0], coef[1], coef[2], coef[3], coef[4]
    min_und, new_t, new_first, new_gyr, max_rej, fac = coef[5], coef[6], coef[7], coef[8], coef[9], coef[10]
    n = math.sqrt(mx * mx + my * my + mz * mz)
    if n == 0.0:
        return 1.0
    dip = -math.asin(max(-1.0, min(1.0, mz / n)))
    if state[10] == 0.0:
        state[8], state[9] = n, dip
    else:
        state[8] += k_cur * (n - state[8])
        state[9] += k_cur * (dip - state[9])
    state[10] += 1.0
    n, dip = state[8], state[9]
    # detection against the reference
    if abs(n - state[0]) < norm_th * state[0] and abs(dip - state[1]) < dip_th:
        state[2] += dt
        if state[2] >= min_und:
            state[6] = 0.0
            state[0] += k_ref * (n - state[0])
            state[1] += k_ref * (dip - state[1])
    else:
        state[2] = 0.0
        state[6] = 1.0
    # acceptance of a new field
    if abs(n - state[3]) < norm_th * state[3] and abs(dip - state[4]) < dip_th:
        if gyr_lp_norm >= new_gyr:
            state[5] += dt
        state[3] += k_ref * (n - state[3])
        state[4] += k_ref * (dip - state[4])
        if state[6] != 0.0 and (state[5] >= new_t or (state[0] == 0.0 and state[5] >= new_first)):
            state[0], state[1] = state[3], state[4]
            state[6] = 0.0
            state[2] = min_und
    else:
        state[5] = 0.0
        state[3], state[4] = n, dip
    # rejection
    if state[6] != 0.0:
        if state[7] <= max_rej:
            state[7] += dt
            return 0.0
        return 1.0 / fac
    state[7] = max(state[7] - fac * dt, 0.0)
    return 1.0


# --- (b) rest detection and bias --------------------------------------------------------------------
def rest_coefficients(dt_s: float, tau_rest_s: float = 0.5, th_gyr_dps: float = 2.0, th_acc: float = 0.5,
                      min_rest_s: float = 1.5, tau_bias_s: float = 2.0, bias_clip_dps: float = 2.0) -> np.ndarray:
    """Coefficients (7,) of the rest block; thresholds and times are VQF's defaults (``th_acc`` m/s^2).

    Raises ``ValueError`` naming a parameter that is not a positive finite number.
    """
    _check_positive("rest", dt_s=dt_s, tau_rest_s=tau_rest_s, th_gyr_dps=th_gyr_dps, th_acc=th_acc,
                    min_rest_s=min_rest_s, tau_bias_s=tau_bias_s, bias_clip_dps=bias_clip_dps)
    return np.array([dt_s, lp_gain(tau_rest_s, dt_s), math.radians(th_gyr_dps) ** 2, th_acc ** 2, min_rest_s,
                     lp_gain(tau_bias_s, dt_s), math.radians(bias_clip_dps)], dtype=np.float64)


def rest_state(bias_rps: np.ndarray | None = None) -> np.ndarray:
    """Initial rest state with an optional initial bias (3,) rad/s."""
    s = np.zeros(REST_STATE)
    if bias_rps is not None:
        s[8:11] = np.asarray(bias_rps, float)
    return s


@njit
def _rest_update(state, coef, gx, gy, gz, ax, ay, az):
    """One gyro (rad/s) and acc sample; updates rest flag and bias in place, returns True at rest."""
    dt, k, th_g2, th_a2, min_t, k_b, clip = coef[0], coef[1], coef[2], coef[3], coef[4], coef[5], coef[6]
    if state[11] == 0.0:
        state[0], state[1], state[2] = gx, gy, gz
        state[3], state[4], state[5] = ax, ay, az
    else:
        state[0] += k * (gx - state[0])
        state[1] += k * (gy - state[1])
        state[2] += k * (gz - state[2])
        state[3] += k * (ax - state[3])
        state[4] += k * (ay - state[4])
        state[5] += k * (az - state[5])
    state[11] += 1.0
    dg = (gx - state[0]) ** 2 + (gy - state[1]) ** 2 + (gz - state[2]) ** 2
    da = (ax - state[3]) ** 2 + (ay - state[4]) ** 2 + (az - state[5]) ** 2
    still = dg < th_g2 and da < th_a2 and max(abs(state[0]), abs(state[1]), abs(state[2])) <= clip
    if still:
        state[6] += dt
    else:
        state[6] = 0.0
    state[7] = 1.0 if (still and state[6] >= min_t) else 0.0
    if state[7] != 0.0:
        for i in range(3):
            b = state[8 + i] + k_b * (state[i] - state[8 + i])
            state[8 + i] = max(-clip, min(clip, b))
    return state[7] != 0.0


# --- (c) acceleration through translation -----------------------------------------------------------
def acc_lp_coefficients(dt_s: float, tau_acc_s: float = 3.0, gravity: float = 9.81, gate_norm: float = 0.2,
                        gate_angle_deg: float = 20.0) -> np.ndarray:
    """Coefficients (4,) of the acceleration block: low-pass gain, g (m/s^2), norm gate (fraction of g),
    angle gate (rad). ``tau_acc_s`` is VQF's ``tauAcc``; 0 disables the low-pass.
    """
    _check_positive("acc", dt_s=dt_s, gravity=gravity, gate_norm=gate_norm, gate_angle_deg=gate_angle_deg)
    return np.array([lp_gain(tau_acc_s, dt_s), gravity, gate_norm, math.radians(gate_angle_deg)], dtype=np.float64)


def acc_lp_state() -> np.ndarray:
    return np.zeros(ACC_STATE)


@njit(cache=True, inline="always")
def _rot(qw, qx, qy, qz, vx, vy, vz, sign):
    """Rotate v by q (sign +1: sensor -> earth of a sensor-to-earth q) or by conj(q) (sign -1)."""
    qx, qy, qz = sign * qx, sign * qy, sign * qz
    tx = 2.0 * (qy * vz - qz * vy)
    ty = 2.0 * (qz * vx - qx * vz)
    tz = 2.0 * (qx * vy - qy * vx)
    return (vx + qw * tx + qy * tz - qz * ty, vy + qw * ty + qz * tx - qx * tz, vz + qw * tz + qx * ty - qy * tx)


@njit
def acc_lp_step(k, s0, s1, s2, n, qw, qx, qy, qz, ax, ay, az):
    """One step of block (c) on scalars: the acc ``(ax, ay, az)`` rotated into the earth frame of sensor-to-earth
    ``q``, low-passed with gain ``k`` (state ``s0, s1, s2``; ``n`` samples so far, the first one initialises it)
    and rotated back. Returns ``(s0, s1, s2, n, ox, oy, oz)``: the new state and the low-passed acc in sensor
    coordinates, which a kernel uses instead of the raw acc.

    Scalars in and out, so a kernel's call carries no array (numba keeps an atomic reference count of every array
    argument of a call, per sample): Madgwick and Mahony call it per sample without inlining it in numba's IR,
    which had cost their cold compile a third."""
    ex, ey, ez = _rot(qw, qx, qy, qz, ax, ay, az, 1.0)
    if n == 0.0:
        s0, s1, s2 = ex, ey, ez
    else:
        s0 += k * (ex - s0)
        s1 += k * (ey - s1)
        s2 += k * (ez - s2)
    ox, oy, oz = _rot(qw, qx, qy, qz, s0, s1, s2, -1.0)
    return s0, s1, s2, n + 1.0, ox, oy, oz


@njit(cache=True)
def _acc_gate(coef, q, ax, ay, az):
    """Weight 1 or 0 of an accelerometer update: |acc| near g and acc near the gravity predicted by ``q``."""
    n = math.sqrt(ax * ax + ay * ay + az * az)
    g = coef[1]
    if n == 0.0 or abs(n - g) > coef[2] * g:
        return 0.0
    ux, uy, uz = _rot(q[0], q[1], q[2], q[3], 0.0, 0.0, 1.0, -1.0)  # earth up in sensor coordinates
    c = (ax * ux + ay * uy + az * uz) / n
    return 1.0 if math.acos(max(-1.0, min(1.0, c))) <= coef[3] else 0.0
