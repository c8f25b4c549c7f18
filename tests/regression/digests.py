"""Digests of what the refactorings must leave bit-identical: filter outputs and short run histories.

:func:`filter_digests` runs every attitude filter (defaults, and the robust blocks switched on where a
filter offers them) on short synthetic recordings; :func:`run_digests` runs short tunings of a filter,
a controller and a test function (serial, and the filter on the ``threads`` backend) and digests their
``history.csv`` without the wall-time column. ``pinned_digests.json`` holds the values computed before
the engine and domain were split into their present rooms; ``python -m tests.regression.digests``
prints the current ones.
"""

from __future__ import annotations

import hashlib
import importlib.util
import json
from pathlib import Path

import numpy as np
import pandas as pd

PINNED = Path(__file__).with_name("pinned_digests.json")

#: (label, filter, params, generator); generator "bench6dof" (9-D) or "tilt1d" (1-D)
FILTER_CASES: tuple[tuple[str, str, dict, str], ...] = (
    ("kf1d", "kf1d", {}, "tilt1d"),
    ("akf1d", "akf1d", {}, "tilt1d"),
    ("mahony1d", "mahony1d", {}, "tilt1d"),
    ("madgwick1d", "madgwick1d", {}, "tilt1d"),
    ("ekf", "ekf", {}, "bench6dof"),
    ("ekf_euler_imu", "ekf", {"integration": "euler", "use_mag": False}, "bench6dof"),
    ("ekf_robust", "ekf", {"mag_rejection": True, "rest_bias": True, "acc_lp_tau_s": 3.0}, "bench6dof"),
    ("faekf", "faekf", {}, "bench6dof"),
    ("madgwick", "madgwick", {}, "bench6dof"),
    ("madgwick_c", "madgwick", {"variant": "original_c", "zeta": 0.01}, "bench6dof"),
    ("madgwick_robust", "madgwick", {"mag_rejection": True, "rest_bias": True, "acc_lp_tau_s": 3.0}, "bench6dof"),
    ("mahony", "mahony", {"Ki": 0.01}, "bench6dof"),
    ("mahony_robust", "mahony", {"mag_rejection": True, "rest_bias": True, "acc_lp_tau_s": 3.0}, "bench6dof"),
    ("lcf", "lcf", {}, "bench6dof"),
    ("ncf", "ncf", {}, "bench6dof"),
    ("ccf", "ccf", {}, "bench6dof"),
    ("ccf_robust", "ccf", {"mag_rejection": True, "acc_lp_tau_s": 3.0}, "bench6dof"),
    ("qukf", "qukf", {}, "bench6dof"),
    ("qraukf", "qraukf", {}, "bench6dof"),
    ("qraukf_robust", "qraukf", {"mag_rejection": True, "rest_bias": True, "acc_lp_tau_s": 3.0}, "bench6dof"),
)

HAVE_VQF = importlib.util.find_spec("vqf") is not None


def _sha(a: np.ndarray) -> str:
    return hashlib.sha256(np.ascontiguousarray(a, dtype=np.float64).tobytes()).hexdigest()[:16]


def recordings() -> dict:
    """The two short synthetic recordings the filter cases run on."""
    from objectives.attitude.data.cache import synthetic

    return {"bench6dof": synthetic("bench6dof", duration_s=4.0, rate_hz=200.0, seed=5, disk_cache=False),
            "tilt1d": synthetic("tilt1d", duration_s=4.0, rate_hz=200.0, seed=5, disk_cache=False)}


def filter_digests() -> dict[str, str]:
    """``{case label: sha256 prefix of the (N, 4) output quaternions}`` for every case of FILTER_CASES."""
    from objectives.attitude.filters import get_filter

    recs = recordings()
    out = {}
    for label, name, params, gen in FILTER_CASES:
        out[label] = _sha(get_filter(name)(**params).run(recs[gen]))
    return out


def _history_digest(run_dir: Path) -> str:
    h = pd.read_csv(Path(run_dir) / "history.csv", keep_default_na=False).drop(columns="seconds")
    return hashlib.sha256(h.to_csv(index=False).encode()).hexdigest()[:16]


def run_configs(tmp: Path) -> dict[str, dict]:
    """Short versions of recorded configs (configs/ekf_bench6dof.yaml, wmp_lqr.yaml, rosenbrock.yaml)."""
    bench = [{"synthetic": {"generator": "bench6dof", "duration_s": 6, "rate_hz": 200, "seed": s}} for s in (1, 2)]
    ekf = {"name": "g-ekf", "seed": 7, "output": str(tmp),
           "objective": {"kind": "filter", "filter": "ekf", "data": {"train": bench},
                         "metric": "euler_mse_geomean", "metric_options": {"normalize": True}, "warmup_s": 1.0},
           "parameters": {"q_q": {"low": 1e-9, "high": 1e-3, "scale": "log"},
                          "q_w": {"low": 1e-13, "high": 1e-6, "scale": "log"},
                          "rho": {"low": 1e-3, "high": 1e3, "scale": "log"}},
           "optimizer": {"method": "pso", "population": 6, "generations": 3}, "parallel": {"backend": "serial"}}
    madgwick = {**ekf, "name": "g-madgwick",
                "objective": {**ekf["objective"], "filter": "madgwick", "metric": "euler_rmse_mean"},
                "parameters": {"beta": {"low": 1e-3, "high": 1.0, "scale": "log"},
                               "zeta": {"low": 1e-4, "high": 0.1, "scale": "log"}},
                "optimizer": {"method": "cmaes", "population": 6, "generations": 3},
                "parallel": {"backend": "threads", "n_jobs": 2}}
    lqr = {"name": "g-lqr", "seed": 1, "output": str(tmp),
           "objective": {"kind": "closed_loop", "plant": "wmp", "controller": "lqr", "profile": "thesis_2s",
                         "duration_s": 4.0, "cost": {"alpha1": 1.4, "alpha2": 0.85, "beta": 1.6, "gamma": 0.4},
                         "noise_seed": 0},
           "optimizer": {"method": "de", "population": 6, "generations": 3}, "parallel": {"backend": "serial"}}
    rosen = {"name": "g-rosen", "seed": 3, "output": str(tmp),
             "objective": {"kind": "function", "function": "rosenbrock", "dim": 3},
             "optimizer": {"method": "trust_region", "max_evals": 30}, "parallel": {"backend": "serial"}}
    return {"ekf_pso": ekf, "madgwick_cmaes_threads": madgwick, "lqr_de": lqr, "rosenbrock_trust_region": rosen}


def run_digests(tmp: Path) -> dict[str, str]:
    """``{case: digest of history.csv without the seconds column}`` of the short runs of :func:`run_configs`."""
    from tuner.config import config_from_dict
    from tuner.run import run

    out = {}
    for label, raw in run_configs(Path(tmp)).items():
        cfg = config_from_dict(raw, source=str(Path(tmp) / f"{label}.yaml"), base_dir=Path(tmp))
        res = run(cfg, run_dir=Path(tmp) / label, quiet=True, report=False)  # only history.csv is digested
        out[label] = _history_digest(res.run_dir)
    return out


if __name__ == "__main__":  # pragma: no cover - regenerating is a deliberate act, reviewed in the diff
    import tempfile

    with tempfile.TemporaryDirectory() as d:
        print(json.dumps({"filters": filter_digests(), "runs": run_digests(Path(d))}, indent=1))
