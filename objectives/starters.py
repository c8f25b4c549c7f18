"""Starter jobs for ``tuner init NAME``: a commented YAML job that tunes filter or controller NAME.

Registered in the entry-point group ``tuner.starters`` (pyproject.toml), one function per objective
kind: ``starter(name) -> str`` (YAML text) or None when the kind has no such name. The searched
parameters are the declaration's default space (``objectives/params.py``) with unit, doc and default
in a comment; every other declared value is listed, commented out, under ``objective.fixed`` with its
default, so a user sees what can be set. The data are synthetic benches, so the job runs anywhere.
"""

from __future__ import annotations

import math
from typing import Any

__all__ = ["filter_starter", "closed_loop_starter"]


def _num(v: Any) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, float) and not math.isfinite(v):
        return ".nan" if v != v else (".inf" if v > 0 else "-.inf")  # YAML's spelling
    if isinstance(v, float):
        text = repr(v) if v != int(v) or abs(v) >= 1e16 else f"{v:.1f}"
        mant, e, exp = text.partition("e")  # YAML 1.1 reads 1e-05 as a string, 1.0e-05 as a number
        return f"{mant}.0e{exp}" if e and "." not in mant else text
    if isinstance(v, str):
        return v
    return str(v)


def _blocks(params: list[dict[str, Any]]) -> tuple[list[str], list[str]]:
    """``parameters:`` lines of the searched values and commented ``fixed:`` lines of the others."""
    searched, fixed = [], []
    for p in params:
        unit = f"{p['unit']}: " if p.get("unit") else ""
        doc = str(p.get("doc", ""))
        note = f"{unit}{doc if len(doc) <= 90 else doc[:87].rsplit(' ', 1)[0] + ' ...'}"
        if p.get("bounds"):
            low, high = p["bounds"]
            scale = p.get("scale") or "linear"
            searched.append(f"  {p['name']}: {{low: {_num(float(low))}, high: {_num(float(high))}, scale: {scale}}}"
                            f"   # {note}; default {_num(p['default'])}")
        else:
            allowed = p.get("allowed")
            listed = p.get("kind") == "choice" and allowed and allowed != [True, False]
            allowed = f" ({', '.join(map(str, allowed))})" if listed else ""
            fixed.append(f"    # {p['name']}: {_num(p['default'])}   # {note}{allowed}")
    return searched, fixed


_TAIL = """optimizer:
  method: auto                   # picks PSO, CMA-ES or a trust region by dimension and budget
  max_evals: {evals}                 # the budget; `tuner describe pso` lists an optimiser's options
parallel: {{backend: loky, n_jobs: 2}}   # serial | loky | threads | dask
"""


def filter_starter(name: str) -> str | None:
    """A job tuning attitude filter ``name`` on synthetic recordings (None when no such filter)."""
    from objectives.attitude.catalog import explain
    from objectives.attitude.filters import filter_names

    if name not in filter_names():
        return None
    d = explain(name)
    searched, fixed = _blocks(d["params"])
    one_d = name.endswith("1d")  # the tilt filters of thesis 3.1 estimate one angle: the 1-D bench, mse_1d
    if one_d:
        data = ("    train: [{synthetic: {generator: tilt1d, duration_s: 60, rate_hz: 800, seed: 1}}]\n"
                "    test: [{synthetic: {generator: tilt1d, duration_s: 60, rate_hz: 800, seed: 2}}]\n")
        metric = "  metric: mse_1d                 # tilt-angle MSE (thesis eq. 3.18)\n"
    else:
        data = ("    train:                       # your own data: {csv: {path, columns, gyr_unit, ...}} or\n"
                "                                 # {broad: {dir, trials}}; `tuner describe csv` lists the keys\n"
                "      - synthetic: {generator: bench6dof, duration_s: 30, rate_hz: 200, seed: 1}\n"
                "      - synthetic: {generator: bench6dof, duration_s: 30, rate_hz: 200, seed: 2}\n"
                "    test:                        # held out: scored after tuning, never used for it\n"
                "      - synthetic: {generator: bench6dof, duration_s: 30, rate_hz: 200, seed: 101}\n")
        metric = ("  metric: euler_rmse_mean        # `tuner list metrics` lists the others\n"
                  "  warmup_s: 2.0                  # seconds at the start of each recording not scored\n")
    fixed_block = "  fixed:                         # values not searched; uncomment a line to set one\n" + "\n".join(
        fixed)
    return (f"# Starter job: tune the {name} filter ({d.get('summary', '')})\n"
            f"# Written by `tuner init {name}`; run it with `tuner run {name}.yaml`.\n"
            f"# `tuner describe {name}` lists every parameter with its unit, bounds and equation.\n"
            f"name: {name}\nseed: 1\nobjective:\n  kind: filter\n  filter: {name}\n"
            f"{fixed_block}\n  data:\n{data}{metric}"
            "parameters:                      # searched: {low, high, scale: linear|log} or {fixed: value}\n"
            + "\n".join(searched) + "\n" + _TAIL.format(evals=200))


def closed_loop_starter(name: str) -> str | None:
    """A job tuning controller ``name`` on the wheeled mobile pendulum (None when no such controller)."""
    from objectives.control.controllers import CONTROLLERS, get_controller

    if name not in CONTROLLERS:
        return None
    cls = get_controller(name)
    if cls.family == "mujoco":
        return _mujoco_starter(name)
    if cls.family != "wmp":
        return _loop_starter(name)
    d = cls.describe()
    searched, fixed = _blocks(d["params"])
    fixed_block = "  fixed:                         # values not searched; uncomment a line to set one\n" + "\n".join(
        fixed)
    return (f"# Starter job: tune the {name} controller ({d.get('summary', '')})\n"
            f"# on the wheeled mobile pendulum of Odry's thesis (chapter 2), cost eq. 2.39.\n"
            f"# Written by `tuner init {name}`; run it with `tuner run {name}.yaml`.\n"
            f"# `tuner describe {name}` lists every parameter with its unit, bounds and equation.\n"
            f"name: {name}\nseed: 1\nobjective:\n  kind: closed_loop\n  plant: wmp\n  controller: {name}\n"
            f"{fixed_block}\n"
            "  plant_params: {}               # plant values by name; empty: the thesis's pendulum\n"
            "  profile: thesis_2s             # reference steps of speed and yaw rate (`tuner list data`)\n"
            "  duration_s: 8.0\n"
            "  cost: {alpha1: 1.4, alpha2: 0.85, beta: 1.6, gamma: 0.4}   # eq. 2.39 weights\n"
            "  requirements: thesis           # the thesis's tracking requirements (a failed one fails)\n"
            "parameters:                      # searched: {low, high, scale: linear|log} or {fixed: value}\n"
            + "\n".join(searched) + "\n" + _TAIL.format(evals=200))


#: the plant of a loop controller's starter: a DC motor's speed (tf), the same motor's position over its
#: speed (ss, two outputs) for the cascade, a mass on a spring (ss) for state feedback
_LOOP_PLANTS = {
    "tf": ("{tf: {num: [0.01], den: [0.005, 0.06, 0.1001]}}   # DC motor speed (rad/s) per volt",
           {"tf": {"num": [0.01], "den": [0.005, 0.06, 0.1001]}}),
    "cascade": ("{ss: {A: [[0, 1], [0, -10]], B: [[0], [2]], C: [[1, 0], [0, 1]]}, output: 0, inner_output: 1}"
                "   # motor position over speed", {"ss": {"A": [[0, 1], [0, -10]], "B": [[0], [2]],
                                                         "C": [[1, 0], [0, 1]]}, "output": 0, "inner_output": 1}),
    "ss": ("{ss: {A: [[0, 1], [-2, -0.5]], B: [[0], [1]], C: [[1, 0]]}}   # mass on a spring-damper",
           {"ss": {"A": [[0, 1], [-2, -0.5]], "B": [[0], [1]], "C": [[1, 0]]}}),
}


#: the example model and scenario of a MuJoCo controller's starter (the repository's configs/examples/mujoco/)
_MUJOCO_EXAMPLES = {
    "lqr_fd": ("cartpole.xml", "keyframe: upright, outputs: [cart_position, hinge]",
               "{duration_s: 5.0, reference: {cart_position: [{t: 1.0, value: 0.5}]}, initial: {hinge: 0.1}, "
               "limits: {hinge: 0.8}}", "{iae: 1.0, effort: 0.0005}"),
    "joint_pid": ("arm2.xml", "keyframe: hanging, outputs: [shoulder, elbow]",
                  "{duration_s: 4.0, reference: {shoulder: [{t: 0.5, value: 1.0}], elbow: [{t: 1.5, value: 0.8}]}}",
                  "{iae: 1.0, effort: 0.0001}"),
}


def _mujoco_starter(name: str) -> str | None:
    """A job tuning MuJoCo controller ``name`` on the repository's example model (a MuJoCo plant's searched
    parameters follow from its model, so the job searches the controller's default space)."""
    if name not in _MUJOCO_EXAMPLES:
        return None
    model, plant, scenario, cost = _MUJOCO_EXAMPLES[name]
    return (f"# Starter job: tune the {name} controller on a MuJoCo model (needs the mujoco extra:\n"
            "# pip install 'tuner[mujoco]').\n"
            f"# The plant is the repository's example model configs/examples/mujoco/{model}: copy that folder beside\n"
            "# this job, or name your own MJCF or URDF file (`tuner describe plant`).\n"
            f"# Written by `tuner init {name}`; run it with `tuner run {name}.yaml`.\n"
            f"# `tuner describe {name}` says which parameters a model gives it (one set per loop or state).\n"
            f"name: {name}\nseed: 1\nobjective:\n  kind: closed_loop\n"
            f"  plant: {{mujoco: mujoco/{model}, {plant}}}\n  controller: {name}\n"
            "  period_s: 0.002                # a whole number of the model's timestep\n"
            f"  scenario: {scenario}\n"
            f"  cost: {cost}\n"
            "  requirements: {}               # e.g. {max_overshoot_pct: 10, max_settling_time_s: 3}\n"
            "  # uncertainty: {parameters: {body.pole.mass: {rel: 0.2}}}   # tune on perturbed models too\n"
            + _TAIL.format(evals=200))


def _loop_starter(name: str) -> str | None:
    """A job tuning loop controller ``name`` on a small example plant (README: closed loop, your own plant)."""
    from objectives.control.objective import ClosedLoopObjective

    if name == "open_loop":
        return None
    key = "cascade" if name == "pid_cascade" else "ss" if name == "lqr_sf" else "tf"
    text, plant = _LOOP_PLANTS[key]
    scenario = {"duration_s": 3.0, "reference": [{"t": 0.1, "value": 1.0}], "load": [{"t": 2.0, "value": 0.5}]}
    obj = ClosedLoopObjective(plant=plant, controller=name, period_s=0.01, scenario=scenario)
    searched, fixed = _blocks(obj.decl.describe())
    summary = (obj.loop.ctrl.__doc__ or "").strip().splitlines()[0]
    fixed_block = "  fixed:                         # values not searched; uncomment a line to set one\n" + "\n".join(
        fixed)
    return (f"# Starter job: tune the {name} controller ({summary})\n"
            "# on an example plant: replace objective.plant with yours (`tuner describe plant`).\n"
            f"# Written by `tuner init {name}`; run it with `tuner run {name}.yaml`.\n"
            f"# `tuner describe {name}` lists every parameter with its unit and bounds.\n"
            f"name: {name}\nseed: 1\nobjective:\n  kind: closed_loop\n  plant: {text}\n  controller: {name}\n"
            f"{fixed_block}\n"
            "  period_s: 0.01                 # controller period (s)\n"
            "  scenario: {duration_s: 3.0, reference: [{t: 0.1, value: 1.0}], load: [{t: 2.0, value: 0.5}]}\n"
            "  # or scenarios: [{name: large, ...}, {name: small, ...}]: steps of several amplitudes, loads, noise,\n"
            "  # each with its weight and requirements (tuner describe scenario)\n"
            "  cost: {iae: 1.0}               # iae, ise, itae, itse, effort, tv, or {mae_product: {e: 1.4, u: 0.4}}\n"
            "  requirements: {}               # e.g. {max_overshoot_pct: 10, max_ms: 1.6} (a failed one fails)\n"
            "  # uncertainty: {parameters: {\"tf.num[0]\": {rel: 0.3}}}   # tune on perturbed plants too\n"
            "  #   (tuner describe uncertainty; requirements.md then gives the pass rate on held-out plants)\n"
            "parameters:                      # searched: {low, high, scale: linear|log} or {fixed: value}\n"
            + "\n".join(searched) + "\n" + _TAIL.format(evals=200))
