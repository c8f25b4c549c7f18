"""What the C export tests share: compiling a filter's C once per configuration and the angle between outputs."""

from __future__ import annotations

import numpy as np
import pytest

from objectives.attitude.cexport import render_c_filter
from objectives.attitude.cexport.build import CFilter, compile_shared, find_compiler
from objectives.attitude.filters.complementary import CCF, LCF, NCF
from objectives.attitude.filters.ekf import EKF
from objectives.attitude.filters.madgwick import Madgwick
from objectives.attitude.filters.mahony import Mahony
from objectives.attitude.filters.realtime import Realtime

needs_cc = pytest.mark.skipif(find_compiler() is None, reason="no C compiler (cc, gcc or clang) on the PATH")

#: filters with non-default fixed options, as the BROAD configs and the papers use them
CONFIGS = {
    "madgwick_paper_robust": lambda: Madgwick(beta=0.034, mag_rejection=True, rest_bias=True, acc_lp_tau_s=3.0),
    "madgwick_c_zeta": lambda: Madgwick(beta=0.12, variant="original_c", zeta=0.02),
    "mahony_robust": lambda: Mahony(Kp=0.7, Ki=0.01, mag_rejection=True, rest_bias=True, acc_lp_tau_s=2.0,
                                    mag_ref_start=False, rest_bias_tau_s=3.0),
    "mahony_imu": lambda: Mahony(Kp=0.74, Ki=0.0012, use_mag=False),
    "ekf_robust": lambda: EKF(p0_b=1e-4, gyro_sample="current", huber_deg=5.0, acc_gate=0.3, mag_rejection=True,
                              rest_bias=True, rho=3.0, acc_lp_tau_s=4.6),
    "ekf_paper_euler": lambda: EKF(integration="euler", use_mag=False),
    "lcf_tau": lambda: LCF(alpha_mode="tau", tau_s=0.5),
    "lcf_alpha_rate": lambda: LCF(alpha=0.9, alpha_rate_hz=100.0),
    "ncf": lambda: NCF(Kp=2.0, Ki=0.05),
    "ccf_static": lambda: CCF(alpha_mode="static"),
    "ccf_robust": lambda: CCF(alpha_mode="tau", tau_s=0.2, Kp=2.0, Ki=0.05, acc_gate=0.3, mag_rejection=True,
                              mag_weight=0.5),
    "ccf_acc_lp": lambda: CCF(acc_lp_tau_s=3.0, acc_gate=0.3),
    "realtime_vqf": lambda: Realtime(),
    "realtime_tuned": lambda: Realtime(start="q0", mag_first_at_rest=True, tau_mag_s=22.46, mag_recover_tau_s=10.98),
    "realtime_6d": lambda: Realtime(use_mag=False, motion_bias=False, tau_acc_s=1.5),
}


def build(flt, tmp_path, rate_hz: float, precision: str = "double", opt=("-O2",), init: str | None = None,
          prefix: str = "T1") -> CFilter:
    """The compiled C of ``flt`` (start as the filter's ``init``, ``accmag`` for ``auto``)."""
    if init is None:
        init = flt.values["init"] if flt.values["init"] in ("accmag", "broad") else "accmag"
    files = render_c_filter(flt, rate_hz=rate_hz, init=init, precision=precision, prefix=prefix)
    d = tmp_path / f"{prefix}-{precision}-{'-'.join(o.strip('-') for o in opt)}-{id(flt)}"
    return CFilter(compile_shared(files, d, tuple(opt)), prefix, precision)


def run_c(c: CFilter, flt, rec, q0=None) -> np.ndarray:
    """The C on a recording, output in the recording's frame (as ``flt.run(rec)``)."""
    from objectives.attitude.quaternion import to_frame

    use_mag = bool(flt.values.get("use_mag", True)) and rec.mag is not None
    q0_enu = None if q0 is None else to_frame(np.asarray(q0, float), rec.frame, "ENU")
    return to_frame(c.run(rec.gyr, rec.acc, rec.mag if use_mag else None, rec.dt, q0_enu), "ENU", rec.frame)


def angle(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Rotation angle (rad) between quaternion rows, accurate for tiny angles."""
    w = np.sum(a * b, axis=1)
    v = a[:, :1] * b[:, 1:] - b[:, :1] * a[:, 1:] - np.cross(a[:, 1:], b[:, 1:])
    return 2.0 * np.arctan2(np.linalg.norm(v, axis=1), np.abs(w))
