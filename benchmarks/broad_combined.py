"""Fast combined rotation and translation: a proxy recording built from two real BROAD trials.

Issue 12 measured the Kalman filters at about 18 deg on BROAD recordings of fast combined rotation and
translation, a motion mix with no trial of its own among the 16 shared ones. This module rebuilds that
motion from real data: the fast rotation of one trial (07 or 09) carries the linear acceleration of a fast
translation trial (15 or 18).

Conventions (BROAD, :func:`objectives.attitude.data.broad.load_broad`): ``quat`` is the sensor-to-earth
quaternion ``(w, x, y, z)`` in ENU (z up), ``acc`` the specific force in the sensor frame (``+g`` along up at
rest), so ``R(q) acc = a_lin + g e_z``. The translation trial's linear acceleration in the earth frame is

    a_lin_earth(t) = R_trans(t) acc_trans(t) - g e_z

(its optical ground truth and its accelerometer), and the proxy's accelerometer is the rotation trial's plus
that acceleration seen in the rotation trial's sensor frame:

    acc_new(t) = acc_rot(t) + R_rot(t)^T a_lin_earth(t + shift)

Gyroscope, magnetometer, ground truth and motion mask stay the rotation trial's. ``shift`` aligns the first
motion sample of both trials (``align="motion"``; ``"start"`` aligns sample 0); the recording is cut to the
common length. Where either trial's truth is unknown (markers lost), ``a_lin_earth`` is 0. :func:`gravity_check`
verifies the convention on the rest stretch before the motion: ``|R(q) acc - g e_z|`` is then the accelerometer
noise plus the truth's tilt error (about 0.1-0.2 m/s^2), against 2 g for the wrong sign.

Run ``python benchmarks/broad_combined.py`` for the table of benchmarks/results/broad_cv.md (total RMSE over the
motion samples and per quarter of them, so an error growing through the recording shows).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:  # run as a script
    sys.path.insert(0, str(ROOT))

from objectives.attitude.data.recording import Recording  # noqa: E402
from objectives.attitude.quaternion import qrot_batch  # noqa: E402

__all__ = ["linear_acc_earth", "gravity_check", "combined_recording", "quarter_errors", "SETUPS"]

GRAVITY = 9.81


def linear_acc_earth(rec: Recording, gravity: float = GRAVITY) -> np.ndarray:
    """``R(q) acc - g e_z`` (N, 3), m/s^2, earth frame of ``rec``; NaN rows where the truth is unknown."""
    if rec.quat is None:
        raise ValueError(f"{rec.name}: linear_acc_earth needs the ground-truth quaternion (rec.quat is None)")
    if rec.frame != "ENU":
        raise ValueError(f"{rec.name}: linear_acc_earth expects an ENU recording (z up), got frame {rec.frame!r}")
    q = np.asarray(rec.quat, float)
    ok = np.isfinite(q).all(axis=1)
    out = np.full((q.shape[0], 3), np.nan)
    qn = q[ok] / np.linalg.norm(q[ok], axis=1, keepdims=True)
    out[ok] = qrot_batch(qn, rec.acc[ok])
    out[ok, 2] -= gravity
    return out


def _motion_start(rec: Recording) -> int:
    m = np.asarray(rec.motion, bool)
    if not m.any():
        raise ValueError(f"{rec.name}: no motion sample (motion mask all False)")
    return int(np.argmax(m))


def gravity_check(rec: Recording, gravity: float = GRAVITY) -> float:
    """Median ``|R(q) acc - g e_z|`` (m/s^2) over the rest samples before the first motion sample.

    Small (accelerometer noise and truth tilt error) when the conventions hold; about ``2 g`` if the
    quaternion were earth-to-sensor upside down or gravity had the other sign.
    """
    n0 = _motion_start(rec)
    a = linear_acc_earth(rec, gravity)[:n0]
    a = a[np.isfinite(a).all(axis=1)]
    if a.shape[0] == 0:
        raise ValueError(f"{rec.name}: no rest sample with known truth before the motion")
    return float(np.median(np.linalg.norm(a, axis=1)))


def combined_recording(rot: Recording, trans: Recording, align: str = "motion", gain: float = 1.0,
                       gravity: float = GRAVITY) -> Recording:
    """The rotation trial ``rot`` with the linear acceleration of ``trans`` added (module docstring).

    Parameters
    ----------
    rot, trans : Recording
        ENU recordings with ground truth and the same sampling time.
    align : {"motion", "start"}
        Align the first motion samples of both trials, or their first samples.
    gain : float
        Scale of the added linear acceleration (1: as recorded; 0 gives back ``rot``'s accelerometer).

    Returns
    -------
    Recording named ``"<rot>+<trans>"``, cut to the common length; ``extra["lin_acc_earth"]`` (N, 3) holds the
    added earth-frame acceleration (0 where unknown).
    """
    if abs(rot.dt - trans.dt) > 1e-9 * rot.dt:
        raise ValueError(f"combined_recording: sampling times differ ({rot.name}: {rot.dt} s, {trans.name}: "
                         f"{trans.dt} s)")
    if align not in ("motion", "start"):
        raise ValueError(f"combined_recording: align must be 'motion' or 'start', got {align!r}")
    if rot.quat is None or rot.mag is None:
        raise ValueError(f"combined_recording: {rot.name} needs ground truth and magnetometer")
    shift = _motion_start(trans) - _motion_start(rot) if align == "motion" else 0
    lin = linear_acc_earth(trans, gravity)
    n = rot.gyr.shape[0]
    idx = np.arange(n) + shift
    n = int(min(n, trans.gyr.shape[0] - shift))  # common length
    if n < 2:
        raise ValueError(f"combined_recording: {rot.name} and {trans.name} overlap by {n} samples")
    idx = idx[:n]
    a_lin = np.zeros((n, 3))
    inside = idx >= 0
    a_lin[inside] = lin[idx[inside]]
    q_rot = np.asarray(rot.quat[:n], float)
    ok = np.isfinite(q_rot).all(axis=1) & np.isfinite(a_lin).all(axis=1)
    a_lin[~ok] = 0.0
    a_lin *= gain
    acc = np.array(rot.acc[:n], float)
    qn = q_rot[ok] / np.linalg.norm(q_rot[ok], axis=1, keepdims=True)
    acc[ok] += qrot_batch(qn, a_lin[ok], inverse=True)
    return Recording(name=f"{rot.name}+{trans.name}", gyr=rot.gyr[:n], acc=acc, mag=rot.mag[:n], dt=rot.dt,
                     quat=rot.quat[:n], motion=np.asarray(rot.motion[:n], bool), frame=rot.frame,
                     units=dict(rot.units), source=f"{rot.source} + linear acc of {trans.source}",
                     extra={"lin_acc_earth": a_lin})


def quarter_errors(q_est: np.ndarray, rec: Recording) -> dict[str, float]:
    """BROAD total/heading/inclination RMSE (deg) over the motion samples and total RMSE per quarter of them."""
    from objectives.attitude.metrics import broad_errors

    e = broad_errors(q_est, rec.quat, rec.motion)
    out = {"total": e.total_rmse_deg, "heading": e.heading_rmse_deg, "incl": e.inclination_rmse_deg}
    idx = np.flatnonzero(np.asarray(rec.motion, bool))
    for i, part in enumerate(np.array_split(idx, 4)):
        m = np.zeros(rec.gyr.shape[0], bool)
        m[part] = True
        out[f"q{i + 1}"] = broad_errors(q_est, rec.quat, m).total_rmse_deg
    return out


_EKF_FIXED = {"p0_b": 1.0e-4, "gyro_sample": "current", "huber_deg": 5.0, "acc_gate": 0.3, "mag_rejection": True,
              "rest_bias": True}
#: (label, filter, parameters): the shipped configs' fixed options, with their tuned parameters (broad_cv.md) and
#: their defaults; "issue-12 ekf" is the EKF as first configured (blocks off, acc gate and q_w near the bounds the
#: tuning found then).
SETUPS = [
    ("ekf, broad_ekf tuned (rho 9.49, lp 4.64 s)", "ekf", {**_EKF_FIXED, "rho": 9.49, "acc_lp_tau_s": 4.64}),
    ("ekf, broad_ekf defaults (no lp)", "ekf", dict(_EKF_FIXED)),
    ("ekf, issue-12 style (blocks off, gate 0.05, q_w 3.5e-13)", "ekf",
     {"p0_b": 1.0e-4, "gyro_sample": "current", "huber_deg": 5.0, "acc_gate": 0.05, "q_w": 3.5e-13}),
    ("faekf, broad_faekf tuned (rho 1.905, lp 4.288 s)", "faekf", {**_EKF_FIXED, "rho": 1.905, "acc_lp_tau_s": 4.288}),
    ("faekf, broad_faekf defaults (no lp)", "faekf", dict(_EKF_FIXED)),
    ("qraukf, paper", "qraukf", {}),
    ("qraukf, broad_qraukf defaults (rest_bias)", "qraukf", {"rest_bias": True}),
    ("qraukf, broad_qraukf tuned (rest_bias, sigma_acc 0.232)", "qraukf", {"rest_bias": True, "sigma_acc": 0.2321}),
    ("vqf, broad_vqf tuned (tauAcc 2.32, tauMag 24.9)", "vqf", {"tauAcc": 2.322, "tauMag": 24.86}),
    ("vqf, defaults", "vqf", {}),
    ("vqf offline, broad_best (tauAcc 3, tauMag 18)", "vqf", {"offline": True, "tauAcc": 3.0, "tauMag": 18.0}),
]

PAIRS = [("07_undisturbed_fast_rotation_B", "15_undisturbed_fast_translation_A"),
         ("09_undisturbed_fast_rotation_with_breaks_B", "18_undisturbed_fast_translation_with_breaks_B")]


def main(argv: list[str] | None = None) -> int:
    from benchmarks.broad_cv_common import BROAD_DIR
    from objectives.attitude.data.broad import load_broad
    from objectives.attitude.filters import get_filter

    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--data", default=str(BROAD_DIR), help="BROAD directory (default: ../shared/data/broad)")
    ap.add_argument("--only", nargs="*", help="labels (substrings) of SETUPS to run")
    ap.add_argument("--set", nargs="*", default=[], metavar="LABEL:FILTER:JSON",
                    help="extra setups, e.g. 'qraukf tuned:qraukf:{\"rest_bias\": true, \"sigma_acc\": 0.3}'")
    ap.add_argument("--with-plain", action="store_true", help="also score the rotation trials unchanged")
    a = ap.parse_args(argv)
    import json

    setups = [s for s in SETUPS if not a.only or any(o in s[0] for o in a.only)]
    for item in a.set:
        label, fname, js = item.split(":", 2)
        setups.append((label, fname, json.loads(js)))
    recs = []
    for r_name, t_name in PAIRS:
        rot = load_broad(Path(a.data) / f"{r_name}.mat")
        trans = load_broad(Path(a.data) / f"{t_name}.mat")
        print(f"gravity check (median |R acc - g e_z| at rest, m/s^2): {rot.name[:2]} {gravity_check(rot):.3f}, "
              f"{trans.name[:2]} {gravity_check(trans):.3f}")
        if a.with_plain:
            recs.append(rot)
        recs.append(combined_recording(rot, trans))
    print("| setup | recording | total | heading | inclination | q1 | q2 | q3 | q4 |")
    print("|---|---|---|---|---|---|---|---|---|")
    for label, fname, params in setups:
        f = get_filter(fname)(**params)
        for rec in recs:
            t0 = time.time()
            e = quarter_errors(f.run(rec), rec)
            short = "+".join(p[:2] for p in rec.name.split("+"))
            print(f"| {label} | {short} | {e['total']:.2f} | {e['heading']:.2f} | {e['incl']:.2f} | "
                  + " | ".join(f"{e[f'q{i}']:.2f}" for i in range(1, 5)) + f" |  <!-- {time.time() - t0:.1f} s -->",
                  flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
