"""Scenario, measurement, cost and step metrics of the MuJoCo loop (several outputs and inputs at once).

YAML (``objective:``)::

    scenario:
      duration_s: 5.0
      reference: {cart: [{t: 1.0, value: 0.5}]}   # per output: steps or ramps (the generic loop's items,
                                                  # values absolute) or a profile {t: [...], value: [...]}
      initial: {hinge: 0.1}          # joint position offsets from the operating point at t = 0 (rad or m)
      initial_velocity: {hinge: 0.0} # joint velocity offsets (rad/s or m/s)
      limits: {hinge: 0.8}           # |output| above its limit ends the run as failed (the pendulum fell)
    sensor: {noise_std: 0.001, delay_s: 0.0, seed: 0}   # noise per measured signal (a number for all, or
                                                        # {name: std}); a measurement delay; the noise's seed
    cost: {iae: 1.0, effort: 0.001, weights: {hinge: 2.0}}

Every output has a reference: its scenario entry, or else its value at the operating point (a regulator
holds it there); the error of output ``i`` is ``e_i = r_i - y_i``. Cost terms (h the period, t from the
start, summed over outputs with their ``weights``, default 1): IAE ``sum |e| h``, ISE ``sum e^2 h``, ITAE
``sum t |e| h``, ITSE ``sum t e^2 h``; over the controlled inputs: ``effort = sum (u - u_op)^2 h`` and
``tv = sum |u[k] - u[k-1]|``. The measured signals are the state (state feedback) or the outputs; their
noise is drawn once from ``sensor.seed`` (every candidate sees the same), the delay is a whole number of
periods. Step metrics (the generic loop's: overshoot, 10-90 % rise, 2 % settling, steady-state error) are
taken on each output's first reference step, from its operating value; a requirement holds for the worst
output.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from objectives.control.plants.cost import TERMS
from objectives.control.plants.mujoco.steps import STEP_METRICS, first_step, step_metrics
from objectives.control.plants.scenario import Scenario, _num, scenario_from_spec

__all__ = ["MjScenario", "scenario_for", "Measurement", "measurement_for", "cost_for", "loop_cost", "step_table",
           "STEP_METRICS"]



@dataclass(frozen=True)
class MjScenario:
    """The scenario sampled at the period: ``t`` (N,), ``r`` (N, p) absolute references, ``r_op`` (p,) the
    outputs' operating values, ``tracked`` (outputs with a reference of their own), ``qpos_offset`` (nq,),
    ``qvel_offset`` (nv,), ``ylim`` (p,) (``inf`` where none)."""

    t: np.ndarray
    r: np.ndarray
    r_op: np.ndarray
    tracked: tuple[int, ...]
    qpos_offset: np.ndarray
    qvel_offset: np.ndarray
    ylim: np.ndarray

    def output_scenario(self, i: int) -> Scenario:
        """Output ``i``'s reference as a generic scenario, measured from its operating value."""
        return Scenario(self.t, self.r[:, i] - self.r_op[i], np.zeros_like(self.t))


def _joint_offsets(plant: Any, spec: Any, key: str, velocity: bool) -> np.ndarray:
    import mujoco

    m = plant.mj
    out = np.zeros(m.nv if velocity else m.nq)
    if spec is None:
        return out
    if not isinstance(spec, Mapping):
        raise ValueError(f"{key}: expected a mapping {{joint: offset}}, got {spec!r}")
    names = [mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_JOINT, j) for j in range(m.njnt)]
    for name, v in spec.items():
        if name not in names:
            raise ValueError(f"{key}.{name}: no joint named {name!r} in the model; its joints: "
                             f"{[n for n in names if n]}")
        j = names.index(name)
        if int(m.jnt_type[j]) in (int(mujoco.mjtJoint.mjJNT_FREE), int(mujoco.mjtJoint.mjJNT_BALL)):
            raise ValueError(f"{key}.{name}: a free or ball joint; offsets are for hinge and slide joints")
        out[int(m.jnt_dofadr[j]) if velocity else int(m.jnt_qposadr[j])] = _num(f"{key}.{name}", v)
    return out


def scenario_for(plant: Any, spec: Any, period_s: float, key: str = "objective.scenario") -> MjScenario:
    """The validated scenario of ``spec`` on ``plant`` (module docstring); ``ValueError`` naming the key."""
    spec = dict(spec or {})
    allowed = {"duration_s", "reference", "initial", "initial_velocity", "limits"}
    unknown = sorted(set(spec) - allowed)
    if unknown:
        raise ValueError(f"{key}.{unknown[0]}: unknown key; allowed: {sorted(allowed)}")
    if "duration_s" not in spec:
        raise ValueError(f"{key}.duration_s: missing; the simulated time (s)")
    base = scenario_from_spec({"duration_s": spec["duration_s"], "reference": []}, period_s, key)
    t, names = base.t, plant.output_names
    r_op = plant.operating_outputs()
    r = np.tile(r_op, (t.size, 1))
    refs = spec.get("reference") or {}
    if not isinstance(refs, Mapping):
        raise ValueError(f"{key}.reference: expected a mapping {{output: steps or profile}}; outputs: {names}")
    tracked = []
    for name, items in refs.items():
        if name not in names:
            raise ValueError(f"{key}.reference.{name}: not an output of the plant; outputs: {names}")
        i = names.index(name)
        if isinstance(items, list):  # absolute values: steps of the change from the operating value
            shifted = [{**it, "value": it["value"] - r_op[i]} if isinstance(it, Mapping) and "value" in it
                       and isinstance(it["value"], (int, float)) and not isinstance(it["value"], bool) else it
                       for it in items]
        elif isinstance(items, Mapping) and isinstance(items.get("value"), list):
            shifted = {**items, "value": [float(v) - r_op[i] if isinstance(v, (int, float)) else v
                                          for v in items["value"]]}
        else:
            shifted = items
        dev = scenario_from_spec({"duration_s": spec["duration_s"], "reference": shifted}, period_s,
                                 f"{key}.reference.{name}").r
        r[:, i] = r_op[i] + dev
        tracked.append(i)
    ylim = np.full(len(names), np.inf)
    lims = spec.get("limits") or {}
    if not isinstance(lims, Mapping):
        raise ValueError(f"{key}.limits: expected a mapping {{output: largest |value|}}, got {lims!r}")
    for name, v in lims.items():
        if name not in names:
            raise ValueError(f"{key}.limits.{name}: not an output of the plant; outputs: {names}")
        ylim[names.index(name)] = _num(f"{key}.limits.{name}", v, 0.0, strict=True)
    return MjScenario(t, np.ascontiguousarray(r), r_op, tuple(sorted(tracked)),
                      _joint_offsets(plant, spec.get("initial"), f"{key}.initial", False),
                      _joint_offsets(plant, spec.get("initial_velocity"), f"{key}.initial_velocity", True), ylim)


@dataclass(frozen=True)
class Measurement:
    """The measured signals' names, the noise std per signal, the delay (s) and the noise's seed."""

    names: tuple[str, ...]
    noise_std: np.ndarray
    delay_s: float
    seed: int

    def delay_n(self, period_s: float) -> int:
        return int(round(self.delay_s / period_s))

    def noise(self, n: int, std: np.ndarray | None = None) -> np.ndarray:
        """(n, len(names)) noise of the seed, scaled by ``std`` (this measurement's by default)."""
        std = self.noise_std if std is None else std
        if not np.any(std > 0):
            return np.zeros((n, len(self.names)))
        return np.random.default_rng(self.seed).standard_normal((n, len(self.names))) * std


def measurement_for(spec: Any, names: list[str], period_s: float, key: str = "objective.sensor") -> Measurement:
    """The validated ``sensor`` section for the measured signals ``names``."""
    spec = dict(spec or {})
    unknown = sorted(set(spec) - {"noise_std", "delay_s", "seed"})
    if unknown:
        raise ValueError(f"{key}.{unknown[0]}: unknown key; allowed: delay_s, noise_std, seed")
    raw = spec.get("noise_std", 0.0)
    if isinstance(raw, Mapping):
        std = np.zeros(len(names))
        for name, v in raw.items():
            if name not in names:
                raise ValueError(f"{key}.noise_std.{name}: not a measured signal; measured: {names}")
            std[names.index(name)] = _num(f"{key}.noise_std.{name}", v, 0.0)
    else:
        std = np.full(len(names), _num(f"{key}.noise_std", raw, 0.0))
    delay = _num(f"{key}.delay_s", spec.get("delay_s", 0.0), 0.0)
    if abs(delay / period_s - round(delay / period_s)) > 1e-6:
        raise ValueError(f"{key}.delay_s: {delay:g} s is not a whole number of controller periods ({period_s:g} s)")
    seed = spec.get("seed", 0)
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise ValueError(f"{key}.seed: must be an integer >= 0, got {seed!r}")
    return Measurement(tuple(names), std, delay, seed)


def cost_for(spec: Any, outputs: list[str], key: str = "objective.cost") -> tuple[dict[str, float], np.ndarray]:
    """``(terms and weights, output weights)`` of the ``cost`` section (default ``{iae: 1}``)."""
    spec = dict(spec or {"iae": 1.0})
    weights = np.ones(len(outputs))
    w = spec.pop("weights", None) or {}
    if not isinstance(w, Mapping):
        raise ValueError(f"{key}.weights: expected a mapping {{output: weight}}, got {w!r}")
    for name, v in w.items():
        if name not in outputs:
            raise ValueError(f"{key}.weights.{name}: not an output of the plant; outputs: {outputs}")
        weights[outputs.index(name)] = _num(f"{key}.weights.{name}", v, 0.0)
    terms = {}
    for k, v in spec.items():
        if k not in TERMS:
            raise ValueError(f"{key}.{k}: unknown term; allowed: {list(TERMS)} and weights")
        terms[k] = _num(f"{key}.{k}", v, 0.0)
    if not terms:
        raise ValueError(f"{key}: give at least one term of {list(TERMS)}")
    return terms, weights


def loop_cost(terms: Mapping[str, float], weights: np.ndarray, t: np.ndarray, e: np.ndarray, du: np.ndarray,
              h: float) -> tuple[float, dict[str, float]]:
    """``(cost, every term)`` of one run: errors ``e`` (N, p), inputs from the operating point ``du`` (N, m)."""
    ae = np.abs(e)
    step = np.diff(du, axis=0)
    vals = {"iae": float((ae.sum(axis=0) * weights).sum() * h),
            "ise": float(((e * e).sum(axis=0) * weights).sum() * h),
            "itae": float(((t[:, None] * ae).sum(axis=0) * weights).sum() * h),
            "itse": float(((t[:, None] * e * e).sum(axis=0) * weights).sum() * h),
            "effort": float((du * du).sum() * h), "tv": float(np.abs(step).sum())}
    return float(sum(w * vals[k] for k, w in terms.items())), vals


def step_table(sc: MjScenario, y: np.ndarray, h: float, names: list[str]) -> dict[str, float]:
    """The step metrics of every tracked output that steps (``<metric>_<output>``) and their worst
    (``<metric>``: the largest; NaN when no output steps)."""
    out: dict[str, float] = {}
    seen: dict[str, list[float]] = {k: [] for k in STEP_METRICS}
    for i in sc.tracked:
        osc = sc.output_scenario(i)
        if first_step(osc.r) is None:
            continue
        for k, v in step_metrics(osc.r, y[:, i] - sc.r_op[i], h).items():
            out[f"{k}_{names[i]}"] = v
            seen[k].append(v)
    for k, vals in seen.items():  # NaN (not measurable) wins: a requirement on it is not met
        out[k] = math.nan if not vals or any(math.isnan(v) for v in vals) else max(vals)
    return out
