"""Scenario, actuator/sensor realism, costs, step metrics and requirements of the generic loop.

YAML (``objective:``)::

    scenario:
      duration_s: 5.0
      reference: [{t: 0.5, value: 1.0}, {t: 3.0, value: 0.0, ramp_s: 0.5}]  # steps, or ramps over ramp_s
      # or a profile: reference: {t: [0, 1, 2], value: [0, 1, 1]}  (piecewise linear)
      load: [{t: 2.0, value: 0.2}]          # load-disturbance steps added to plant input 0
    actuator: {u_min: -12, u_max: 12, rate_limit: 100.0, quantum: 0.01}   # u units, u/s
    sensor: {noise_std: 0.001, quantum: 0.0, seed: 0}                      # noise per measured signal
    cost: {iae: 1.0, effort: 0.01}          # weighted sum of terms (TERMS), or
    cost: {mae_product: {e: 1.4, u: 0.4}}   # thesis eq. 2.39 generalised: prod mean(|s|)^w
    requirements: {max_overshoot_pct: 5, max_settling_time_s: 1.0, max_ms: 1.4, min_phase_margin_deg: 45}

Cost terms over the whole run (e = r - y of the controlled output, t from the start, h the period):
IAE = sum |e| h, ISE = sum e^2 h, ITAE = sum t |e| h, ITSE = sum t e^2 h, ``effort`` = sum u^2 h,
``tv`` = sum |u[k] - u[k-1]| (total variation). ``mae_product`` signals: ``e``, ``u``, ``du`` (u rate,
1/s), ``y<i>`` (output i), ``x<i>`` (state i).

Step metrics (requirements) on the first reference step (t0, r0 -> r1) up to the next change of
the reference or of the load, or the end: overshoot in % of the step, 10-90 % rise time, 2 % settling time after t0,
steady-state error ``|r1 - y|`` at the end of that window; ``peak_u`` = max |u| over the run.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from tuner.sizes import samples

__all__ = ["Scenario", "scenario_from_spec", "Realism", "realism_from_spec", "cost_from_spec", "loop_cost",
           "step_metrics", "REQUIREMENTS", "check_requirements", "TERMS"]

TERMS = ("iae", "ise", "itae", "itse", "effort", "tv")
#: requirement key -> (metric, "max" or "min", what)
REQUIREMENTS = {
    "max_overshoot_pct": ("overshoot_pct", "max", "overshoot (%)"),
    "max_rise_time_s": ("rise_time_s", "max", "10-90 % rise time (s)"),
    "max_settling_time_s": ("settling_time_s", "max", "2 % settling time (s)"),
    "max_ss_error": ("ss_error", "max", "steady-state error"),
    "max_peak_u": ("peak_u", "max", "peak |u|"),
    "min_gain_margin_db": ("gm_db", "min", "gain margin (dB)"),
    "min_phase_margin_deg": ("pm_deg", "min", "phase margin (deg)"),
    "max_ms": ("ms", "max", "maximum sensitivity Ms"),
}
#: requirement key -> (lowest allowed value, strict, why): limits no loop can meet are errors up front
_REQ_RANGE = {
    "max_overshoot_pct": (0.0, False, "overshoot is >= 0 %"),
    "max_rise_time_s": (0.0, True, "a time limit must be > 0 s"),
    "max_settling_time_s": (0.0, True, "a time limit must be > 0 s"),
    "max_ss_error": (0.0, False, "the error is an absolute value"),
    "max_peak_u": (0.0, True, "peak |u| is >= 0 and 0 allows no control"),
    "max_ms": (1.0, False, "Ms = max |S| is >= 1 for a strictly proper loop; 1.2-2.0 is usual"),
    "min_phase_margin_deg": (-math.inf, False, ""),
    "min_gain_margin_db": (-math.inf, False, ""),
}
_STEP_METRICS = ("overshoot_pct", "rise_time_s", "settling_time_s", "ss_error")
_MARGIN_METRICS = ("gm_db", "pm_deg", "ms")


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

    def first_step(self) -> tuple[int, int] | None:
        """``(k0, k1)``: the first reference change (a step, or a ramp's start) and the end (exclusive)
        of its window: the next change of the reference after it has stopped moving, or of the load;
        None without a change."""
        ch = np.flatnonzero(np.diff(self.r) != 0) + 1
        if self.r[0] != 0:
            ch = np.r_[0, ch]
        if ch.size == 0:
            return None
        i = 0
        while i + 1 < ch.size and ch[i + 1] == ch[i] + 1:  # a ramp: consecutive changes
            i += 1
        k0, k1 = int(ch[0]), int(ch[i + 1]) if i + 1 < ch.size else len(self.r)
        dl = np.flatnonzero(np.diff(self.load) != 0) + 1
        dl = dl[dl > k0]
        return k0, min(k1, int(dl[0])) if dl.size else k1


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
                             "raise objective.scenario.duration_s or move the step")
        start = np.interp(t0, t, out) if t0 <= t[-1] else out[-1]
        frac = np.clip((t - t0) / ramp, 0.0, 1.0) if ramp > 0 else (t >= t0 - 1e-12).astype(float)
        out = np.where(t >= t0 - 1e-12, start + (v - start) * frac, out)
    return out


def scenario_from_spec(spec: Any, period_s: float, key: str = "objective.scenario") -> Scenario:
    spec = dict(spec or {})
    unknown = sorted(set(spec) - {"duration_s", "reference", "load"})
    if unknown:
        raise ValueError(f"{key}.{unknown[0]}: unknown key; allowed: duration_s, reference, load")
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
    noise = sen.get("noise_std", 0.0)
    noise = tuple(_num(f"objective.sensor.noise_std[{i}]", v, 0.0) for i, v in enumerate(np.atleast_1d(noise).tolist()))
    seed = sen.get("seed", 0)
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise ValueError(f"objective.sensor.seed: must be an integer >= 0, got {seed!r}")
    return Realism(umin, umax, _num("objective.actuator.rate_limit", act.get("rate_limit", 0.0), 0.0),
                   _num("objective.actuator.quantum", act.get("quantum", 0.0), 0.0), noise,
                   _num("objective.sensor.quantum", sen.get("quantum", 0.0), 0.0), seed)


def cost_from_spec(spec: Any) -> dict[str, Any]:
    """Validated ``cost`` (default ``{iae: 1}``)."""
    spec = dict(spec or {"iae": 1.0})
    if "mae_product" in spec:
        if len(spec) != 1 or not isinstance(spec["mae_product"], Mapping) or not spec["mae_product"]:
            raise ValueError("objective.cost.mae_product: give it alone, as {signal: exponent}")
        for s, w in spec["mae_product"].items():
            ok = s in ("e", "u", "du") or (isinstance(s, str) and s[:1] in "xy" and s[1:].isdigit())
            if not ok:
                raise ValueError(f"objective.cost.mae_product.{s}: unknown signal; allowed: e, u, du, y<i>, x<i>")
            _num(f"objective.cost.mae_product.{s}", w, 0.0)
        return {"mae_product": dict(spec["mae_product"])}
    for k, w in spec.items():
        if k not in TERMS:
            raise ValueError(f"objective.cost.{k}: unknown term; allowed: {list(TERMS)} or mae_product")
        _num(f"objective.cost.{k}", w, 0.0)
    return spec


def loop_cost(cost: Mapping[str, Any], t: np.ndarray, e: np.ndarray, u: np.ndarray, y: np.ndarray,
              x: np.ndarray, h: float) -> tuple[float, dict[str, float]]:
    """``(cost, terms)`` of one response (module docstring); terms are always all computed."""
    ae = np.abs(e)
    du = np.diff(u, prepend=u[:1])
    terms = {"iae": float(ae.sum() * h), "ise": float((e * e).sum() * h), "itae": float((t * ae).sum() * h),
             "itse": float((t * e * e).sum() * h), "effort": float((u * u).sum() * h),
             "tv": float(np.abs(du).sum())}
    if "mae_product" in cost:
        f = 1.0
        for s, w in cost["mae_product"].items():
            sig = {"e": e, "u": u, "du": du / h}.get(s)
            if sig is None:
                sig = (y if s[0] == "y" else x)[:, int(s[1:])]
            f *= float(np.mean(np.abs(sig))) ** float(w)
        return f, terms
    return float(sum(float(w) * terms[k] for k, w in cost.items())), terms


def step_metrics(sc: Scenario, y: np.ndarray, h: float) -> dict[str, float]:
    """Overshoot (%), rise time, settling time (s) and steady-state error of the first reference step."""
    win = sc.first_step()
    nan = dict.fromkeys(_STEP_METRICS, math.nan)
    if win is None:
        return nan
    k0, k1 = win
    r0 = sc.r[k0 - 1] if k0 > 0 else 0.0
    rk = sc.r[k0:k1]
    r1 = rk[-1]
    step = r1 - r0
    if step == 0:
        return nan
    yn = (y[k0:k1] - r0) / step  # normalised: 0 before, 1 at the target
    overshoot = max(0.0, float(np.max(yn)) - 1.0) * 100.0
    i10 = np.flatnonzero(yn >= 0.1)
    i90 = np.flatnonzero(yn >= 0.9)
    rise = (i90[0] - i10[0]) * h if i10.size and i90.size else math.inf
    outside = np.flatnonzero(np.abs(yn - 1.0) > 0.02)
    if outside.size == 0:
        settle = 0.0
    elif outside[-1] == yn.size - 1:
        settle = math.inf
    else:
        settle = (outside[-1] + 1) * h
    return {"overshoot_pct": overshoot, "rise_time_s": float(rise), "settling_time_s": float(settle),
            "ss_error": float(abs(r1 - y[k1 - 1]))}


def check_requirements(req: Mapping[str, float], m: Mapping[str, float]) -> str:
    """The first violated requirement as a message ('' if all are met); NaN counts as violated."""
    for key, lim in req.items():
        metric, sense, what = REQUIREMENTS[key]
        v = m.get(metric, math.nan)
        ok = v <= lim if sense == "max" else v >= lim
        if not ok:
            return f"{what} {v:.4g} {'>' if sense == 'max' else '<'} {key} {lim:g}"
    return ""


def requirements_from_spec(spec: Any, has_step: bool, lti: bool, window_s: float = math.inf) -> dict[str, float]:
    """Checked requirement limits; ``window_s``: the first step's window (s), over which a rise or
    settling time is measured (a longer limit could not be checked)."""
    spec = dict(spec or {})
    for k, v in spec.items():
        if k not in REQUIREMENTS:
            raise ValueError(f"objective.requirements.{k}: unknown; allowed: {sorted(REQUIREMENTS)}")
        v = _num(f"objective.requirements.{k}", v)
        lo, strict, why = _REQ_RANGE[k]
        if v < lo or (strict and v == lo):
            raise ValueError(f"objective.requirements.{k}: {v:g} cannot be met; must be {'>' if strict else '>='} "
                             f"{lo:g} ({why})")
        if k == "min_phase_margin_deg" and v >= 180.0:
            raise ValueError(f"objective.requirements.{k}: {v:g} cannot be met; a phase margin is below 180 deg "
                             "(30-60 is usual)")
        if k in ("max_rise_time_s", "max_settling_time_s") and v > window_s:
            raise ValueError(f"objective.requirements.{k}: {v:g} s is longer than the first step's window "
                             f"({window_s:g} s) in which it is measured; raise objective.scenario.duration_s "
                             "or lower the limit")
        metric = REQUIREMENTS[k][0]
        if metric in _STEP_METRICS and not has_step:
            raise ValueError(f"objective.requirements.{k}: needs a reference step in objective.scenario.reference")
        if metric in _MARGIN_METRICS and not lti:
            raise ValueError(f"objective.requirements.{k}: margins and Ms need an LTI plant (tf, zpk, ss)")
    return {k: float(v) for k, v in spec.items()}
