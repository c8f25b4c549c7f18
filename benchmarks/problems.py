"""The real tuning problems the quality and scaling benchmarks share.

Each problem is an objective of the project (picklable, data loaded once per process) and a
:class:`~tuner.space.Space`; optimisers of every library see the same unit cube (log scales
included), so budgets and encodings are equal for all. ``smoke=True`` shrinks the data so a CI run
takes seconds.

=================  ===========================================================================
name               objective
=================  ===========================================================================
madgwick_broad     Madgwick (beta, zeta) on the first 90 s of BROAD 07 (undisturbed fast rotation)
                   and 24 (disturbed tapping), BROAD's mean total RMSE (deg) over motion samples
                   (90 s keeps 10 methods x 10 seeds within the 30 min of ``make bench``)
mahony_broad       Mahony (Kp, Ki) on the same trials and metric
ekf_bench6dof      quaternion EKF (q_q, q_w, rho) on a 20 s synthetic 6-DOF bench recording,
                   FAEKF paper eq. 35 (2 s warm-up left out)
faekf_bench6dof    fuzzy-adaptive EKF (q_q, q_w, rho, K2..K7; K1 = 1), same data and metric
kf1d_tilt1d        the thesis 1-D tilt KF (rho, q00, q11) on a 20 s tilt bench, thesis eq. 3.18
pid_wmp            PID equivalents on the wheeled mobile pendulum, 10 s thesis profile, eq. 2.39
                   (``configs/wmp_pid.yaml``)
fuzzy_wmp          protective fuzzy controller, 15 parameters (``configs/wmp_fuzzy_protective.yaml``,
                   tracking requirements included)
lqr_wmp            LQR weights on the same plant and cost (smoke runs only: its kernel compiles fastest)
=================  ===========================================================================
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from tuner.space import Space

__all__ = ["Problem", "PROBLEMS", "build_problem", "problem_names", "UnitObjective"]

REPO = Path(__file__).resolve().parent.parent
BROAD_TRIALS = ["07_undisturbed_fast_rotation_B", "24_disturbed_tapping_A"]


@dataclass(frozen=True)
class Problem:
    name: str
    objective: Any
    space: Space
    what: str


def _broad_dir() -> Path | None:
    from objectives.attitude.data.broad import default_broad_dir

    d = default_broad_dir()
    return d if d.exists() else None


def _broad_data(smoke: bool) -> list[dict]:
    d = _broad_dir()
    if d is None:
        raise FileNotFoundError("BROAD data not found (../shared/data/broad)")
    if smoke:
        return [{"broad": {"dir": str(d), "trial": BROAD_TRIALS[0], "stop_s": 35.0}}]
    return [{"broad": {"dir": str(d), "trial": t, "stop_s": 90.0}} for t in BROAD_TRIALS]


def _bench_data(generator: str, smoke: bool) -> list[dict]:
    return [{"synthetic": {"generator": generator, "duration_s": 6.0 if smoke else 20.0, "seed": 1}}]


def _filter(name: str, section: dict, params: dict, what: str) -> Problem:
    from objectives.attitude.objective import FilterObjective

    obj = FilterObjective.from_config({"kind": "filter", **section}, REPO)
    space = Space.from_dict(params) if params else obj.default_space()
    return Problem(name, obj, space, what)


def _madgwick(smoke: bool) -> Problem:
    return _filter("madgwick_broad", {"filter": "madgwick", "data": _broad_data(smoke), "metric": "broad_mean_rmse"},
                   {"beta": {"low": 1e-3, "high": 1.0, "scale": "log"},
                    "zeta": {"low": 1e-5, "high": 0.1, "scale": "log"}},
                   "Madgwick MARG (beta, zeta), BROAD 07+24 (first 90 s), mean total RMSE (deg)")


def _mahony(smoke: bool) -> Problem:
    return _filter("mahony_broad", {"filter": "mahony", "data": _broad_data(smoke), "metric": "broad_mean_rmse"},
                   {}, "Mahony MARG (Kp, Ki), BROAD 07+24 (first 90 s), mean total RMSE (deg)")


def _ekf(smoke: bool) -> Problem:
    return _filter("ekf_bench6dof", {"filter": "ekf", "data": _bench_data("bench6dof", smoke),
                                     "metric": "euler_mse_geomean", "warmup_s": 2.0},
                   {}, "EKF (q_q, q_w, rho), bench6dof 20 s, eq. 35")


def _faekf(smoke: bool) -> Problem:
    return _filter("faekf_bench6dof", {"filter": "faekf", "data": _bench_data("bench6dof", smoke),
                                       "fixed": {"window": 400, "fft_length": 512, "f_thr": 10.0, "omega_thr": 0.26},
                                       "metric": "euler_mse_geomean", "warmup_s": 2.0},
                   {}, "FAEKF (q_q, q_w, rho, K2..K7), bench6dof 20 s, eq. 35")


def _kf1d(smoke: bool) -> Problem:
    return _filter("kf1d_tilt1d", {"filter": "kf1d", "data": _bench_data("tilt1d", smoke), "metric": "mse_1d"},
                   {}, "thesis 1-D KF (rho, q00, q11), tilt1d 20 s, eq. 3.18")


def _wmp(controller: str, smoke: bool, config: str | None = None) -> Problem:
    from objectives.control.objective import ClosedLoopObjective

    raw = yaml.safe_load((REPO / "configs" / (config or f"wmp_{controller}.yaml")).read_text())
    section = dict(raw["objective"])
    if smoke:
        section["duration_s"] = 2.0
    obj = ClosedLoopObjective.from_config(section, REPO / "configs")
    return Problem(f"{'fuzzy' if config else controller}_wmp", obj, Space.from_dict(raw["parameters"]),
                   f"{controller} on the WMP, {section['duration_s']:g} s thesis profile, eq. 2.39")


#: the subset a smoke run uses (one per objective family; the LQR kernel compiles fastest)
SMOKE_PROBLEMS = ["mahony_broad", "ekf_bench6dof", "kf1d_tilt1d", "lqr_wmp"]

PROBLEMS = {
    "madgwick_broad": _madgwick,
    "mahony_broad": _mahony,
    "ekf_bench6dof": _ekf,
    "faekf_bench6dof": _faekf,
    "kf1d_tilt1d": _kf1d,
    "pid_wmp": lambda smoke: _wmp("pid", smoke),
    "fuzzy_wmp": lambda smoke: _wmp("protective_fuzzy", smoke, "wmp_fuzzy_protective.yaml"),
    "lqr_wmp": lambda smoke: _wmp("lqr", smoke),
}
#: the seven problems the benchmark issue names (lqr_wmp is extra and only used by smoke runs)
FULL_PROBLEMS = [k for k in PROBLEMS if k != "lqr_wmp"]


def problem_names(smoke: bool = False) -> list[str]:
    return list(SMOKE_PROBLEMS) if smoke else list(FULL_PROBLEMS)


_CACHE: dict[tuple[str, bool], Problem] = {}


def build_problem(name: str, smoke: bool = False) -> Problem:
    """The problem ``name`` (built once per process)."""
    key = (name, bool(smoke))
    if key not in _CACHE:
        _CACHE[key] = PROBLEMS[name](smoke)
    return _CACHE[key]


@dataclass(frozen=True)
class UnitObjective:
    """``f(u)`` for a point ``u`` of the unit cube: decode with the space, return the fitness (float)."""

    objective: Any
    space: Space

    def __call__(self, u: np.ndarray) -> float:
        return float(self.objective(self.space.decode(np.clip(np.asarray(u, float), 0.0, 1.0))).fitness)
