"""What the ``realtime`` kernel starts from: its coefficient and state layouts, declared once (the kernel indexes
``c[C.K_MAG]``, the C port's enums and array sizes come from them), the coefficients derived from the filter's
time constants at a sample time (:func:`coefficients`) and the state before the first sample
(:func:`initial_state`). The kernel: :mod:`objectives.attitude.filters.realtime.kernel`.

Second-order low-pass filters (Butterworth, cutoff ``sqrt(2) / (2 pi tau)``) average their first ``tau``
seconds and start from that mean, so no single first sample dominates (VQF's initialisation).
"""

from __future__ import annotations

import math

import numpy as np

from objectives.attitude.filters.layout import Layout

__all__ = ["C", "S", "LOW_PASSES", "COEF_LEN", "STATE_LEN", "butter2", "coefficients", "initial_state"]


# --- layouts (declared once: the kernel indexes by them, the C port's enums and array sizes come from them) ------
#: the coefficient array: per-sample coefficients derived from the time constants once per run (:func:`coefficients`)
C = Layout("C", (
    ("DT", 1, "sample time, s"),
    ("ACC_LP", 5, "b0, b1, b2, a1, a2 of tau_acc_s (butter2)"),
    ("TAU_ACC", 1, "tau_acc_s, s"),
    ("K_MAG", 1, "heading gain of tau_mag_s"),
    ("TAU_MAG", 1, "tau_mag_s, s"),
    ("USE_MAG", 1, "1: 9-D, 0: 6-D"),
    ("MOTION_BIAS", 1, "0/1"),
    ("REST_BIAS", 1, "0/1"),
    ("MAG_REJ", 1, "0/1"),
    ("BIAS_CLIP", 1, "largest bias, rad/s"),
    ("BIAS_P0", 1, "initial bias variance, (0.01 deg/s)^2 units, as VQF"),
    ("BIAS_V", 1, "bias process noise per sample"),
    ("BIAS_MOTION_W", 1, "variance of the bias measurement in motion"),
    ("BIAS_VERT_W", 1, "and of its vertical component"),
    ("BIAS_REST_W", 1, "variance of the bias measurement at rest"),
    ("REST_LP", 5, "b0 .. a2 of rest_filter_tau_s"),
    ("REST_TAU", 1, "rest_filter_tau_s, s"),
    ("REST_TH_GYR", 1, "rad/s"),
    ("REST_TH_ACC", 1, "m/s^2"),
    ("REST_MIN", 1, "s"),
    ("MAG_LP", 5, "b0 .. a2 of mag_current_tau_s"),
    ("MAG_TAU", 1, "mag_current_tau_s, s (0: no low-pass of norm and dip)"),
    ("K_MAG_REF", 1, "gain of the reference field's low-pass"),
    ("MAG_NORM_TH", 1, "relative norm threshold"),
    ("MAG_DIP_TH", 1, "dip threshold, rad"),
    ("MAG_NEW", 1, "s"),
    ("MAG_NEW_FIRST", 1, "s"),
    ("MAG_NEW_MIN_GYR", 1, "rad/s"),
    ("MAG_MIN_UNDIST", 1, "s"),
    ("MAG_MAX_REJ", 1, "s"),
    ("MAG_REJ_FACTOR", 1, "1"),
    ("MAG_FIRST_AT_REST", 1, "0/1: the first field is accepted without rotation"),
    ("K_MAG_REC", 1, "heading gain while the rejection budget recovers (0: k_mag)"),
))
COEF_LEN = C.LEN
#: the state: everything carried from one sample to the next (resumable; :func:`initial_state`)
S = Layout("S", (
    ("GYR_Q", 4, "strapdown quaternion (sensor to the drifting inertial frame)"),
    ("ACC_Q", 4, "inclination correction (inertial frame to the 6-D earth frame)"),
    ("DELTA", 1, "heading offset of the 6-D earth frame, rad"),
    ("BIAS", 3, "gyro bias, rad/s"),
    ("BIAS_P", 9, "bias covariance"),
    ("ACC_LP", 6, "low-pass state of the inertial-frame accelerometer (2 x 3)"),
    ("R_LP", 18, "low-pass state of the rotation matrix (2 x 9)"),
    ("BLP", 4, "low-pass state of R b (2 x 2)"),
    ("REST_GYR_LP", 6, "rest detection: low-pass state of the gyro (2 x 3)"),
    ("REST_ACC_LP", 6, "and of the accelerometer (2 x 3)"),
    ("REST_T", 1, "time at rest, s"),
    ("REST", 1, "0/1: rest detected"),
    ("REST_GYR", 3, "last low-passed gyro (rest detection)"),
    ("MAG_LP", 4, "low-pass state of norm and dip (2 x 2)"),
    ("MAG_REF_NORM", 1, "reference field norm"),
    ("MAG_REF_DIP", 1, "and dip, rad"),
    ("MAG_UNDIST_T", 1, "time undisturbed, s"),
    ("MAG_REJECT_T", 1, "rejection time budget, s"),
    ("MAG_CAND_NORM", 1, "candidate field norm (-1: none)"),
    ("MAG_CAND_DIP", 1, "and dip, rad"),
    ("MAG_CAND_T", 1, "time of rotation in the candidate field, s"),
    ("MAG_DIST", 1, "0/1: disturbed"),
    ("K_MAG_INIT", 1, "fast-start heading gain (0: over)"),
))
STATE_LEN = S.LEN
#: the state's second-order low-passes (:func:`_lp`; the C port keeps a start phase for each)
LOW_PASSES = ("REST_GYR_LP", "REST_ACC_LP", "ACC_LP", "R_LP", "BLP", "MAG_LP")



def butter2(tau: float, dt: float) -> tuple[float, float, float, float, float]:
    """``(b0, b1, b2, a1, a2)`` of a second-order Butterworth low-pass with time constant ``tau`` s at step
    ``dt`` s (cutoff ``sqrt(2) / (2 pi tau)`` Hz); a pass-through when ``tau < dt / 2`` (cutoff above 90 % of
    Nyquist), as in VQF."""
    if tau < dt / 2.0:
        return 1.0, 0.0, 0.0, 0.0, 0.0
    fc = math.sqrt(2.0) / (2.0 * math.pi * tau)
    c = math.tan(math.pi * fc * dt)
    d = c * c + math.sqrt(2.0) * c + 1.0
    b0 = c * c / d
    return b0, 2.0 * b0, b0, 2.0 * (c * c - 1.0) / d, (1.0 - math.sqrt(2.0) * c + c * c) / d


def _gain(tau: float, dt: float) -> float:
    """First-order gain ``1 - exp(-dt / tau)``; 1 for ``tau = 0``, 0 for ``tau < 0``."""
    if tau < 0.0:
        return 0.0
    if tau == 0.0:
        return 1.0
    return 1.0 - math.exp(-dt / tau)


def coefficients(v: dict, dt: float, use_mag: bool) -> np.ndarray:
    """The coefficient array of the kernel from the filter's values ``v`` (time constants in s, rates in
    deg/s) at sample time ``dt`` s."""
    c = np.zeros(COEF_LEN)
    c[C.DT] = dt
    c[C.ACC_LP:C.ACC_LP + 5] = butter2(v["tau_acc_s"], dt)
    c[C.TAU_ACC] = v["tau_acc_s"]
    c[C.K_MAG] = _gain(v["tau_mag_s"], dt)
    c[C.TAU_MAG] = v["tau_mag_s"]
    c[C.USE_MAG] = float(use_mag)
    c[C.MOTION_BIAS] = float(v["motion_bias"])
    c[C.REST_BIAS] = float(v["rest_bias"])
    c[C.MAG_REJ] = float(v["mag_rejection"])
    c[C.BIAS_CLIP] = math.radians(v["bias_clip_dps"])
    # the bias filter works in units of 0.01 deg/s (well-conditioned numbers, as VQF)
    c[C.BIAS_P0] = (v["bias_sigma_init_dps"] * 100.0) ** 2
    # process noise: the variance grows from 0 to (0.1 deg/s)^2 in bias_forgetting_s
    c[C.BIAS_V] = (0.1 * 100.0) ** 2 * dt / v["bias_forgetting_s"]
    p_motion = (v["bias_sigma_motion_dps"] * 100.0) ** 2
    c[C.BIAS_MOTION_W] = p_motion ** 2 / c[C.BIAS_V] + p_motion
    c[C.BIAS_VERT_W] = c[C.BIAS_MOTION_W] / max(v["bias_vertical_forgetting"], 1e-10)
    p_rest = (v["bias_sigma_rest_dps"] * 100.0) ** 2
    c[C.BIAS_REST_W] = p_rest ** 2 / c[C.BIAS_V] + p_rest
    c[C.REST_LP:C.REST_LP + 5] = butter2(v["rest_filter_tau_s"], dt)
    c[C.REST_TAU] = v["rest_filter_tau_s"]
    c[C.REST_TH_GYR] = math.radians(v["rest_th_gyr_dps"])
    c[C.REST_TH_ACC] = v["rest_th_acc"]
    c[C.REST_MIN] = v["rest_min_s"]
    if v["mag_current_tau_s"] > 0.0:
        c[C.MAG_LP:C.MAG_LP + 5] = butter2(v["mag_current_tau_s"], dt)
    c[C.MAG_TAU] = v["mag_current_tau_s"]
    c[C.K_MAG_REF] = _gain(v["mag_ref_tau_s"], dt)
    c[C.MAG_NORM_TH] = v["mag_norm_th"]
    c[C.MAG_DIP_TH] = math.radians(v["mag_dip_th_deg"])
    c[C.MAG_NEW] = v["mag_new_s"]
    c[C.MAG_NEW_FIRST] = v["mag_new_first_s"]
    c[C.MAG_NEW_MIN_GYR] = math.radians(v["mag_new_min_gyr_dps"])
    c[C.MAG_MIN_UNDIST] = v["mag_min_undisturbed_s"]
    c[C.MAG_MAX_REJ] = v["mag_max_rejection_s"]
    c[C.MAG_REJ_FACTOR] = v["mag_rejection_factor"]
    c[C.MAG_FIRST_AT_REST] = float(v["mag_first_at_rest"])
    c[C.K_MAG_REC] = _gain(v["mag_recover_tau_s"], dt) if v["mag_recover_tau_s"] > 0.0 else 0.0
    return c


def initial_state(coef: np.ndarray, q0: np.ndarray | None = None) -> np.ndarray:
    """The state before the first sample: identity (or ``q0``, ENU sensor-to-earth) as strapdown start,
    low-pass states uninitialised (NaN: they average their first ``tau``), bias 0 with covariance ``P0 I``,
    the magnetic field not yet known (disturbed until a candidate is accepted)."""
    s = np.full(STATE_LEN, np.nan)
    s[S.GYR_Q:S.GYR_Q + 4] = (1.0, 0.0, 0.0, 0.0) if q0 is None else np.asarray(q0, float) / np.linalg.norm(q0)
    s[S.ACC_Q:S.ACC_Q + 4] = (1.0, 0.0, 0.0, 0.0)
    s[S.DELTA] = 0.0
    s[S.BIAS:S.BIAS + 3] = 0.0
    s[S.BIAS_P:S.BIAS_P + 9] = (np.eye(3) * coef[C.BIAS_P0]).ravel()
    s[S.REST_T] = 0.0
    s[S.REST] = 0.0
    s[S.REST_GYR:S.REST_GYR + 3] = 0.0
    s[S.MAG_REF_NORM] = 0.0
    s[S.MAG_REF_DIP] = 0.0
    s[S.MAG_UNDIST_T] = 0.0
    s[S.MAG_REJECT_T] = coef[C.MAG_MAX_REJ]
    s[S.MAG_CAND_NORM] = -1.0
    s[S.MAG_CAND_DIP] = 0.0
    s[S.MAG_CAND_T] = 0.0
    s[S.MAG_DIST] = 1.0
    s[S.K_MAG_INIT] = 1.0
    return s
