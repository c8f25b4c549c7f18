"""``tuner describe`` for the generic loop's settings: requirements, scenario(s), actuator, sensor, cost,
aggregate and uncertainty, each key with its unit and where it is measured, read from the declarations
(:mod:`objectives.control.plants.requirements`, :mod:`.plants.cost`, :mod:`.plants.uncertainty`)."""

from __future__ import annotations

from typing import Any

__all__ = ["SETTINGS", "describe_setting"]

#: the names ``tuner describe`` answers for (``scenarios`` is ``scenario``'s list form)
SETTINGS = ("requirements", "scenario", "scenarios", "actuator", "sensor", "cost", "aggregate", "uncertainty")

_LOOP = "objective: {kind: closed_loop, plant: {tf: {num: [1], den: [1, 1]}}, period_s: 0.01, "


def _p(name: str, unit: str, doc: str, default: Any = None) -> dict[str, Any]:
    return {"name": name, "default": default, "unit": unit, "doc": doc}


def _requirements() -> dict[str, Any]:
    from objectives.control.plants.requirements import REQUIREMENTS

    return {"summary": "limits every tuned loop must meet (a candidate that misses one is a failed evaluation); under "
                       "objective.requirements they hold in every scenario where defined and on every model, under a "
                       "scenario's requirements in that scenario; the units 'output' and 'input' are the plant's own "
                       "(the pendulum, plant: wmp, has the thesis's: requirements: thesis)",
            "usage": _LOOP + "requirements: {max_overshoot_pct: 5, max_settling_time_s: 1.0, max_ms: 1.6}}",
            "params": [_p(r.key, r.unit, f"{r.words} {'<=' if r.sense == 'max' else '>='} limit; {r.where}")
                       for r in REQUIREMENTS.values()]}


def _scenario(name: str) -> dict[str, Any]:
    usage = (_LOOP + "scenario: {duration_s: 3, reference: [{t: 0.1, value: 1}], load: [{t: 2, value: 0.5}]}}"
             if name == "scenario" else
             _LOOP + "scenarios: [{name: large, duration_s: 3, reference: [{t: 0.1, value: 1}]}, {name: small, "
             "duration_s: 3, reference: [{t: 0.1, value: 0.1}], requirements: {max_overshoot_pct: 5}}]}")
    return {"summary": "what the loop is run on: references, load steps and measurement noise over a simulated time "
                       "(scenario: one; scenarios: a list, each also with a name, weight, requirements, sensor and "
                       "cost of its own); the cost aggregates them (aggregate)",
            "usage": usage,
            "params": [_p("duration_s", "s", "simulated time from t = 0"),
                       _p("reference", "output", "set-point steps [{t (s), value, ramp_s (s, optional)}] or a profile "
                          "{t: [...], value: [...]} (piecewise linear); step requirements are measured on the first "
                          "change", [{"t": 0.0, "value": 1.0}]),
                       _p("load", "input", "load-disturbance steps [{t (s), value}] added to plant input 0; load "
                          "requirements are measured from the first", []),
                       _p("name", "-", "scenarios only: letters, digits, _ and -; metrics are <name>.<metric>"),
                       _p("weight", "1", "scenarios only: its weight in the cost's aggregation", 1.0),
                       _p("sensor", "-", "scenarios only: {noise_std, seed} of this scenario's measurement noise "
                          "(default: objective.sensor, seed + index)"),
                       _p("cost", "-", "scenarios only: cost terms for this scenario (default: objective.cost)"),
                       _p("requirements", "-", "scenarios only: limits that hold in this scenario (tuner describe "
                          "requirements)")]}


def _actuator() -> dict[str, Any]:
    return {"summary": "the actuator between the controller and plant input(s), applied every period; with a limit, "
                       "every requirement is also checked small-signal (without limits) in the report",
            "usage": _LOOP + "actuator: {u_min: -24, u_max: 24, rate_limit: 10000, quantum: 0.0}}",
            "params": [_p("u_min", "input", "lower saturation of every input (the controller's own limit and its "
                          "anti-windup default to it)", "-inf"),
                       _p("u_max", "input", "upper saturation", "inf"),
                       _p("rate_limit", "input/s", "largest |du/dt| (0: none)", 0.0),
                       _p("quantum", "input", "resolution of the actuator (u rounded to it; 0: none)", 0.0)]}


def _sensor() -> dict[str, Any]:
    return {"summary": "the measurement the controller sees: the plant's outputs (its states for lqr_sf) plus white "
                       "Gaussian noise drawn once from seed (every candidate and model sees the same), rounded to the "
                       "quantum; requirements and cost are measured on the true output",
            "usage": _LOOP + "sensor: {noise_std: 0.001, quantum: 0.0, seed: 0}}",
            "params": [_p("noise_std", "output", "standard deviation per measured signal (one value, or one per "
                          "signal)", 0.0),
                       _p("quantum", "output", "resolution of the measurement (0: none)", 0.0),
                       _p("seed", "-", "seed of the noise (scenario i: seed + i unless it sets its own)", 0)]}


def _cost() -> dict[str, Any]:
    from objectives.control.plants.requirements import METRIC_WORDS

    terms = [_p(k, METRIC_WORDS[k][1], f"{METRIC_WORDS[k][0]} over the whole scenario (weight)")
             for k in ("iae", "ise", "itae", "itse", "effort", "tv")]
    return {"summary": "what is minimised: a weighted sum of terms of one response (e = reference - output of the "
                       "controlled output, t from the scenario's start), or a product of mean |signal|^exponent; "
                       "per scenario and model, then aggregated (aggregate); the pendulum (plant: wmp) takes eq. "
                       "2.39's exponents instead (tuner describe mae_weighted_cost)",
            "usage": _LOOP + "cost: {iae: 1.0, effort: 0.001}}", "eq": "thesis eq. 2.39 (mae_product)",
            "params": [*terms, _p("mae_product", "-", "{signal: exponent}, signals e, u, du (1/s), y<i>, x<i>: "
                                  "prod mean(|signal|)^exponent, alone")]}


def _aggregate() -> dict[str, Any]:
    return {"summary": "how the costs of the (model, scenario) pairs become one: first over the scenarios of each "
                       "model with their weights, then over the models; mean, worst or {cvar: alpha} (the mean of the "
                       "worst items carrying weight alpha)",
            "usage": _LOOP + "aggregate: {scenarios: mean, models: {cvar: 0.2}}}",
            "params": [_p("scenarios", "-", "mean (weighted) | worst | {cvar: alpha}", "mean"),
                       _p("models", "-", "mean | worst | {cvar: alpha}", "mean")]}


def _uncertainty() -> dict[str, Any]:
    from objectives.control.plants.uncertainty import MAX_CORNERS, NORMAL_CORNER, NORMAL_TRUNC

    return {"summary": "plant parameters known only within a range: the loop tunes on a seeded set of models (the "
                       "nominal plant, the corners, samples) and, after the run, scores the tuned controller on "
                       "held-out models (pass rate of every requirement, worst margins, the cost's distribution)",
            "usage": _LOOP + "uncertainty: {parameters: {'tf.num[0]': {rel: 0.3}, delay_s: [0.0, 0.05]}, "
                             "tune: {corners: true, samples: 4, seed: 1}, validate: {samples: 200, seed: 2}}}",
            "params": [_p("parameters", "the parameter's",
                          "name -> [low, high] | {uniform: [low, high]} | {rel: r} (nominal x (1 -+ r)) | "
                          f"{{normal: {{std, mean}}}} (truncated at {NORMAL_TRUNC:g} std, corners at {NORMAL_CORNER:g} "
                          "std); names: tf.num[i], tf.den[i], zpk.z[i], zpk.p[i], zpk.k, ss.A[i][j] (LTI), "
                          "params.<name> (python), parameters.<name> (fmu), delay_s (every plant; whole periods)"),
                       _p("tune.corners", "-", f"every combination of the parameters' ends (at most {MAX_CORNERS})",
                          True),
                       _p("tune.samples", "models", "models drawn for the tuning set", 4),
                       _p("tune.seed", "-", "seed of those draws", 1),
                       _p("validate.samples", "models", "held-out models, scored after the run", 200),
                       _p("validate.seed", "-", "seed of the held-out draws", 2)]}


def describe_setting(name: str) -> dict[str, Any]:
    """The description of setting ``name`` (one of :data:`SETTINGS`)."""
    body = {"requirements": _requirements, "actuator": _actuator, "sensor": _sensor, "cost": _cost,
            "aggregate": _aggregate, "uncertainty": _uncertainty}.get(name)
    d = body() if body is not None else _scenario(name)
    return {"section": "closed-loop settings", "name": name, **d}
