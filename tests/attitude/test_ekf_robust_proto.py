"""The robust EKF prototype: with every block off it is the EKF, sample for sample; with them on it
survives BROAD's fast translation (trial 15: the plain EKF's inclination runs away to ~36 deg)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from objectives.attitude.data.broad import load_broad
from objectives.attitude.filters._ekf_robust_proto import EKFRobustProto
from objectives.attitude.filters.ekf import EKF
from objectives.attitude.scoring import error_sums

ROOT = Path(__file__).resolve().parents[2]
BROAD = next((p for p in (ROOT.parent / "shared" / "data" / "broad", ROOT.parent.parent / "shared" / "data" / "broad")
              if (p / "trials.json").exists()), None)
BASE = {"p0_b": 1e-4, "gyro_sample": "current", "huber_deg": 5.0, "acc_gate": 0.3}


@pytest.mark.skipif(BROAD is None, reason="BROAD data not found")
def test_blocks_off_is_the_ekf_and_on_fixes_fast_translation():
    rec = load_broad(BROAD / "15_undisturbed_fast_translation_A.mat")
    q_ekf = EKF(**BASE).run(rec)
    q_off = EKFRobustProto(**BASE).run(rec)
    assert np.abs(q_ekf - q_off).max() < 1e-9
    on = EKFRobustProto(**BASE, tau_acc_s=3.0, mag_rejection=True, rest_bias=True)
    res = on.run_detailed(rec)
    e_ekf = error_sums(q_ekf, rec.quat, rec.motion).broad_rmse_deg[0]
    e_on = error_sums(res.quat, rec.quat, rec.motion).broad_rmse_deg[0]
    assert e_ekf > 20.0 and e_on < 5.0
    assert res.diagnostics["rest"].any()  # the trial starts at rest
