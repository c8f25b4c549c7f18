"""Scenarios of the generic loop (references, loads, measurement noise), and the actuator and sensor.

YAML (``objective:``), one scenario (the original form)::

    scenario:
      duration_s: 5.0
      reference: [{t: 0.5, value: 1.0}, {t: 3.0, value: 0.0, ramp_s: 0.5}]  # steps, or ramps over ramp_s
      # or a profile: reference: {t: [0, 1, 2], value: [0, 1, 1]}  (piecewise linear)
      load: [{t: 2.0, value: 0.2}]          # load-disturbance steps added to plant input 0

or several, each with its own weight, requirements, measurement noise and cost::

    scenarios:
      - {name: large, duration_s: 3, reference: [{t: 0.1, value: 1.0}]}
      - {name: small, duration_s: 3, reference: [{t: 0.1, value: 0.1}], requirements: {max_overshoot_pct: 5}}
      - {name: load, duration_s: 3, reference: [], load: [{t: 0.1, value: 0.5}], weight: 0.5}
      - {name: noise, duration_s: 2, reference: [], sensor: {noise_std: 0.01, seed: 4}, cost: {tv: 1.0},
         requirements: {max_u_std: 0.5}}
    actuator: {u_min: -12, u_max: 12, rate_limit: 100.0, quantum: 0.01}   # u units, u/s
    sensor: {noise_std: 0.001, quantum: 0.0, seed: 0}                      # noise per measured signal

A scenario's name is letters, digits, ``_`` and ``-`` (its metrics are ``<name>.<metric>`` when there are
several); its ``weight`` (default 1) enters the cost's aggregation (:mod:`.cost`); ``sensor`` sets its own
noise (``noise_std`` and ``seed``; default: the job's ``sensor``, the seed of scenario i being the job's
seed + i); ``cost`` replaces the job's cost terms for it; ``requirements`` hold in it in addition to the
job's (:mod:`.requirements`). The measurement noise is drawn once per scenario from its seed, so every
candidate and every model sees the same noise.
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from objectives.control.plants.cost import cost_from_spec
from objectives.control.plants.metrics import windows
from objectives.control.plants.requirements import REQUIREMENTS, check_limit, requirements_from_spec
from tuner.sizes import check_samples, samples

__all__ = ["Scenario", "scenario_from_spec", "Realism", "realism_from_spec", "Case", "cases_from_config"]

_NAME = re.compile(r"^[A-Za-z0-9_-]+$")
_CASE_KEYS = ("name", "weight", "duration_s", "reference", "load", "sensor", "cost", "requirements")


def _num(key: str, v: Any, lo: float = -math.inf, strict: bool = False) -> float:
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or v < lo or (strict and v == lo):
        rel = ">" if strict else ">="
        raise ValueError(f"{key}: must be a finite number {rel} {lo:g}, got {v!r}")
    return float(v)


@dataclass(frozen=True)
class Scenario:
    """Reference and load signals sampled at the period: ``r`` (N,), ``load`` (N,), ``t`` (N,) s."""

    t: np.ndarray
    r: np.ndarray
    load: np.ndarray


def _steps(key: str, items: Any, t: np.ndarray) -> np.ndarray:
    """A signal of steps (or ramps) ``[{t, value, ramp_s}]``: each item moves to ``value`` from ``t``."""
    if not isinstance(items, list):
        raise ValueError(f"{key}: expected a list of {{t, value}} (ramp_s optional), got {items!r}")
    out = np.zeros_like(t)
    last_t = -math.inf
    for i, it in enumerate(items):
        if not isinstance(it, Mapping) or not {"t", "value"} <= set(it) <= {"t", "value", "ramp_s"}:
            raise ValueError(f"{key}[{i}]: expected {{t, value}} and optionally ramp_s, got {it!r}")
        t0, v = _num(f"{key}[{i}].t", it["t"], 0.0), _num(f"{key}[{i}].value", it["value"])
        ramp = _num(f"{key}[{i}].ramp_s", it.get("ramp_s", 0.0), 0.0)
        if t0 < last_t:
            raise ValueError(f"{key}[{i}].t: times must increase, got {t0} after {last_t}")
        last_t = t0
        if t0 > t[-1]:
            raise ValueError(f"{key}[{i}].t: {t0} s is after the end of the scenario ({t[-1]:g} s); "
                             "raise the scenario's duration_s or move the step")
        start = np.interp(t0, t, out) if t0 <= t[-1] else out[-1]
        frac = np.clip((t - t0) / ramp, 0.0, 1.0) if ramp > 0 else (t >= t0 - 1e-12).astype(float)
        out = np.where(t >= t0 - 1e-12, start + (v - start) * frac, out)
    return out


def scenario_from_spec(spec: Any, period_s: float, key: str = "objective.scenario") -> Scenario:
    """The signals of one scenario mapping (``duration_s``, ``reference``, ``load``; other keys are the
    caller's to check)."""
    spec = dict(spec or {})
    if "duration_s" not in spec:
        raise ValueError(f"{key}.duration_s: missing; the simulated time (s)")
    dur = _num(f"{key}.duration_s", spec["duration_s"], 0.0, strict=True)
    n = samples(f"{key}.duration_s", dur, period_s, "the scenario")  # before any array of that length
    if n < 2:
        raise ValueError(f"{key}.duration_s: {dur} s is shorter than two controller periods ({period_s} s)")
    t = np.arange(n) * period_s
    ref = spec.get("reference", [{"t": 0.0, "value": 1.0}])
    if isinstance(ref, Mapping):
        if set(ref) != {"t", "value"}:
            raise ValueError(f"{key}.reference: a profile needs exactly t and value lists, got {sorted(ref)}")
        tp, vp = np.asarray(ref["t"], dtype=float), np.asarray(ref["value"], dtype=float)
        if tp.shape != vp.shape or tp.ndim != 1 or tp.size < 1 or np.any(np.diff(tp) <= 0) \
                or not np.all(np.isfinite(np.r_[tp, vp])):
            raise ValueError(f"{key}.reference: t (increasing) and value must be finite lists of one length")
        r = np.interp(t, tp, vp)
    else:
        r = _steps(f"{key}.reference", ref, t)
    load = _steps(f"{key}.load", spec.get("load", []), t)
    return Scenario(t, np.ascontiguousarray(r), np.ascontiguousarray(load))


@dataclass(frozen=True)
class Realism:
    """Actuator and sensor options (``opt`` entries of the kernels) and the noise std per signal."""

    u_min: float = -math.inf
    u_max: float = math.inf
    rate_limit: float = 0.0
    u_quantum: float = 0.0
    noise_std: tuple[float, ...] = (0.0,)
    y_quantum: float = 0.0
    seed: int = 0

    @property
    def limited(self) -> bool:
        """Whether the actuator limits u: a finite bound or a rate limit (then requirements are also
        checked small-signal)."""
        return self.u_min > -1e299 or self.u_max < 1e299 or self.rate_limit > 0


def _noise(key: str, v: Any) -> tuple[float, ...]:
    return tuple(_num(f"{key}[{i}]", x, 0.0) for i, x in enumerate(np.atleast_1d(v).tolist()))


def _seed(key: str, v: Any) -> int:
    if isinstance(v, bool) or not isinstance(v, int) or v < 0:
        raise ValueError(f"{key}: must be an integer >= 0, got {v!r}")
    return v


def realism_from_spec(actuator: Any, sensor: Any) -> Realism:
    act, sen = dict(actuator or {}), dict(sensor or {})
    bad = sorted(set(act) - {"u_min", "u_max", "rate_limit", "quantum"})
    if bad:
        raise ValueError(f"objective.actuator.{bad[0]}: unknown key; allowed: u_min, u_max, rate_limit, quantum")
    bad = sorted(set(sen) - {"noise_std", "quantum", "seed"})
    if bad:
        raise ValueError(f"objective.sensor.{bad[0]}: unknown key; allowed: noise_std, quantum, seed")
    umin = _num("objective.actuator.u_min", act.get("u_min", -1e300))
    umax = _num("objective.actuator.u_max", act.get("u_max", 1e300))
    if umin >= umax:
        raise ValueError(f"objective.actuator: u_min {umin} must be below u_max {umax}")
    return Realism(umin, umax, _num("objective.actuator.rate_limit", act.get("rate_limit", 0.0), 0.0),
                   _num("objective.actuator.quantum", act.get("quantum", 0.0), 0.0),
                   _noise("objective.sensor.noise_std", sen.get("noise_std", 0.0)),
                   _num("objective.sensor.quantum", sen.get("quantum", 0.0), 0.0),
                   _seed("objective.sensor.seed", sen.get("seed", 0)))


@dataclass(frozen=True)
class Case:
    """One scenario as the loop runs it.

    Attributes
    ----------
    name, weight : str, float
        Its name and its weight in the cost's aggregation.
    signals : Scenario
        t, r, load (N,).
    sig : (N, 2 + n_meas) float64
        What the loop kernel reads: r, load and the measurement noise.
    win : (6,) float64
        The step and load windows (:func:`objectives.control.plants.metrics.windows`).
    cost : dict
        Its cost terms (:func:`objectives.control.plants.cost.cost_from_spec`).
    limits : dict
        Requirement key -> limit in force in this scenario (the job's where defined, then its own).
    own : frozenset of str
        The requirement keys given in the scenario itself.
    noise_std, seed : tuple of float, int
        Its measurement noise (std per measured signal) and the seed it was drawn from.
    """

    name: str
    weight: float
    signals: Scenario
    sig: np.ndarray
    win: np.ndarray
    cost: dict[str, Any]
    limits: dict[str, float]
    own: frozenset[str] = field(default_factory=frozenset)
    noise_std: tuple[float, ...] = (0.0,)
    seed: int = 0

    @property
    def has_step(self) -> bool:
        return self.win[0] >= 0 and self.win[3] != self.win[2]

    @property
    def has_load(self) -> bool:
        return self.win[4] >= 0

    @property
    def step_size(self) -> float:
        return float(self.win[3] - self.win[2]) if self.has_step else math.nan

    def defines(self, scope: str) -> bool:
        """Whether this scenario defines the quantities of a requirement scope (:mod:`.requirements`)."""
        return {"step": self.has_step, "load": self.has_load, "signal": True, "margin": False}[scope]

    def effective_limit(self, key: str) -> float:
        """The limit a check compares with: ``max_ss_error: 0`` is the tolerance times the step."""
        from objectives.control.plants.requirements import SS_TOLERANCE

        lim = self.limits[key]
        if key == "max_ss_error" and lim == 0.0:
            return SS_TOLERANCE * abs(self.step_size)
        return lim


def _case(i: int, spec: Mapping[str, Any], key: str, period_s: float, n_meas: int, real: Realism,
          cost: dict[str, Any], job_req: Mapping[str, Any], named: bool) -> Case:
    if not isinstance(spec, Mapping):
        raise ValueError(f"{key}: expected a mapping (duration_s, reference, load, ...), got {spec!r}")
    allowed = _CASE_KEYS if named else ("duration_s", "reference", "load")
    unknown = sorted(set(spec) - set(allowed))
    if unknown:
        raise ValueError(f"{key}.{unknown[0]}: unknown key; allowed: {', '.join(allowed)}")
    name = spec.get("name", f"scenario{i + 1}" if named else "scenario")
    if not isinstance(name, str) or not _NAME.match(name):
        raise ValueError(f"{key}.name: letters, digits, _ and - only, got {name!r}")
    weight = _num(f"{key}.weight", spec.get("weight", 1.0), 0.0)
    sc = scenario_from_spec(spec, period_s, key)
    sen = spec.get("sensor") or {}
    if not isinstance(sen, Mapping) or set(sen) - {"noise_std", "seed"}:
        raise ValueError(f"{key}.sensor: a mapping of noise_std and seed (the job's sensor.quantum holds for "
                         f"every scenario), got {sen!r}")
    std = _noise(f"{key}.sensor.noise_std", sen["noise_std"]) if "noise_std" in sen else real.noise_std
    seed = _seed(f"{key}.sensor.seed", sen["seed"]) if "seed" in sen else real.seed + i
    arr = np.array(std, dtype=float)
    if arr.size not in (1, n_meas):
        where = f"{key}.sensor.noise_std" if "noise_std" in sen else "objective.sensor.noise_std"
        raise ValueError(f"{where}: one value or {n_meas} (one per measured signal), got {arr.size}")
    n = sc.t.size
    noise = np.random.default_rng(seed).standard_normal((n, n_meas)) * arr if np.any(arr > 0) \
        else np.zeros((n, n_meas))
    sig = np.ascontiguousarray(np.column_stack([sc.r, sc.load, noise]))
    own = requirements_from_spec(spec.get("requirements"), f"{key}.requirements")
    c = cost_from_spec(spec["cost"], f"{key}.cost") if spec.get("cost") is not None else cost
    win = windows(sc.r, sc.load)
    case = Case(name, weight, sc, sig, win, c, {}, frozenset(own), std, seed)
    limits: dict[str, float] = {}
    for src, req in (("objective.requirements", job_req), (f"{key}.requirements", own)):
        for k, v in req.items():
            r = REQUIREMENTS[k]
            if r.scope == "margin":
                if src != "objective.requirements":
                    raise ValueError(f"{src}.{k}: margins and Ms are properties of the loop on each model, not of "
                                     "a scenario; give them under objective.requirements")
                continue
            if not case.defines(r.scope):
                if src == "objective.requirements":
                    continue  # holds where defined; checked below that some scenario defines it
                what = "a reference step (reference)" if r.scope == "step" else "a load step (load)"
                raise ValueError(f"{src}.{k}: needs {what} in this scenario")
            window_s = (win[1] - win[0]) * period_s if r.scope == "step" else math.inf
            limits[k] = check_limit(k, v, src, window_s)
    return Case(name, weight, sc, sig, win, c, limits, frozenset(own), std, seed)


def _check_total(scenarios: list[Any], period_s: float) -> None:
    """The samples of all scenarios of a list together (each holds its signals and noise) against
    :data:`tuner.sizes.MAX_SAMPLES`, before any is built (a duration that is not a number is left to
    :func:`scenario_from_spec`'s error)."""
    total = 0
    for i, spec in enumerate(scenarios):
        dur = spec.get("duration_s") if isinstance(spec, Mapping) else None
        if isinstance(dur, bool) or not isinstance(dur, (int, float)) or not math.isfinite(dur) or dur <= 0:
            continue
        key = f"objective.scenarios[{i}].duration_s"
        total += samples(key, dur, period_s, "the scenario")
        check_samples(key, total, f"the scenarios up to scenarios[{i}] together")


def cases_from_config(scenario: Any, scenarios: Any, period_s: float, n_meas: int, real: Realism,
                      cost: dict[str, Any], job_req: Mapping[str, Any]) -> list[Case]:
    """The scenarios of a job: ``scenarios`` (a list) or the single ``scenario`` (a mapping; the default
    ``{duration_s: required}``); ``ValueError`` naming the key otherwise."""
    if scenarios is not None:
        if scenario:
            raise ValueError("objective.scenarios: give scenario (one) or scenarios (a list), not both")
        if not isinstance(scenarios, list) or not scenarios:
            raise ValueError(f"objective.scenarios: expected a non-empty list of scenario mappings, got {scenarios!r}")
        _check_total(scenarios, period_s)
        cases = [_case(i, s, f"objective.scenarios[{i}]", period_s, n_meas, real, cost, job_req, True)
                 for i, s in enumerate(scenarios)]
        names = [c.name for c in cases]
        dup = sorted({n for n in names if names.count(n) > 1})
        if dup:
            raise ValueError(f"objective.scenarios: names must differ, {dup[0]!r} is given twice")
        if sum(c.weight for c in cases) <= 0:
            raise ValueError("objective.scenarios: the weights are all 0; at least one scenario must count")
    else:
        if scenario is not None and not isinstance(scenario, Mapping):
            raise ValueError(f"objective.scenario: expected a mapping, got {scenario!r}")
        cases = [_case(0, scenario or {}, "objective.scenario", period_s, n_meas, real, cost, job_req, False)]
    for k in job_req:
        r = REQUIREMENTS[k]
        if r.scope != "margin" and not any(k in c.limits for c in cases):
            what = "a reference step (reference)" if r.scope == "step" else "a load step (load)"
            where = "objective.scenario.reference" if scenarios is None and r.scope == "step" else "a scenario"
            raise ValueError(f"objective.requirements.{k}: needs {what} in {where}")
    return cases
