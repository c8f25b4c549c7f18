"""Uncertain MuJoCo plants: the ``uncertainty:`` block of every plant (:mod:`objectives.control.plants.uncertainty`)
over a MuJoCo model's named parameters and its sensor.

YAML (``objective:``), the same grammar as for an LTI, Python or FMU plant::

    uncertainty:
      parameters:                       # name -> range or distribution
        body.pole.mass: {rel: 0.2}                 # uniform in nominal x (1 -+ 0.2)
        joint.hinge.damping: [0.0, 0.02]           # uniform in [low, high]
        actuator.push.gain: {normal: {std: 0.05}}  # mean: the nominal value; truncated at +-3 std
        sensor.delay_s: [0.0, 0.01]                # the measurement delay (s, rounded to whole periods)
        sensor.noise_scale: [0.5, 2.0]             # a factor on every measured signal's noise (nominal 1)
      tune: {corners: true, samples: 8, seed: 1}   # the tuning set: nominal + 2^k corners + samples
      validate: {samples: 100, seed: 2}            # the held-out set, scored after the run
    aggregate: {models: mean}           # the cost over the models: mean | worst | {cvar: alpha}

The names are the plant's named parameters (:mod:`.parameters`: ``body.<b>.mass``, ``body.<b>.ixx``,
``joint.<j>.damping``, ``joint.<j>.frictionloss``, ``actuator.<a>.gain``, ``geom.<g>.friction``, ...) and the
measurement's ``sensor.delay_s`` and ``sensor.noise_scale`` (:data:`SENSOR_PARAMETERS`). The shared block checks
the names and draws both model sets (:func:`~objectives.control.plants.uncertainty.draw_models`); this module
turns each drawn model into a :class:`ModelCase`: the plant's values (:meth:`.model.MujocoPlant.with_parameters`,
equal to building the spec with them in ``parameters``), the delay in periods and the noise factor.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from types import SimpleNamespace
from typing import Any

import numpy as np

from objectives.control.plants.cost import Aggregation, aggregation_from_spec, combine
from objectives.control.plants.uncertainty import Uncertainty as Block
from objectives.control.plants.uncertainty import draw_models
from objectives.control.plants.uncertainty import uncertainty_from_spec as block_from_spec

__all__ = ["ModelCase", "MujocoUncertainty", "uncertainty_from_spec", "over_models", "aggregation_from_spec",
           "SENSOR_PARAMETERS"]

#: the measurement's perturbable values besides the model's named parameters, with their nominal values' meaning
SENSOR_PARAMETERS = ("sensor.delay_s", "sensor.noise_scale")
#: fields that must stay positive in a perturbed model (a normal's tail or a wide range may reach 0)
_POSITIVE = ("mass", "ixx", "iyy", "izz", "gain")
_NONNEGATIVE = ("damping", "frictionloss", "armature", "stiffness")


@dataclass(frozen=True)
class ModelCase:
    """One model of a set: its label, the plant parameter values, the delay (periods) and the noise factor."""

    label: str
    values: dict[str, float]
    delay_n: int
    noise_scale: float


@dataclass(frozen=True)
class MujocoUncertainty:
    """The checked block (:class:`objectives.control.plants.uncertainty.Uncertainty`) on one MuJoCo plant."""

    block: Block
    delay_n: int
    period_s: float

    @property
    def held_out(self) -> int:
        return self.block.validate_samples

    def _case(self, label: str, values: Mapping[str, float]) -> ModelCase:
        delay, noise, plant = self.delay_n, 1.0, {}
        for name, v in values.items():
            if name == "sensor.delay_s":
                delay = max(0, int(round(v / self.period_s)))
            elif name == "sensor.noise_scale":
                noise = max(0.0, float(v))
            elif v != self.block.nominal[name]:
                field = name.rsplit(".", 1)[1]
                v = float(v)
                plant[name] = max(v, 1e-12) if field in _POSITIVE else max(v, 0.0) if field in _NONNEGATIVE else v
        return ModelCase(label, plant, delay, noise)

    def _set(self, which: str) -> list[ModelCase]:
        d = draw_models(self.block, which, self.period_s)
        return [self._case(label, values) for label, values in zip(d.labels, d.values)]

    def tuning_set(self) -> list[ModelCase]:
        """The nominal model, the corners (with ``tune.corners``), the seeded samples."""
        return self._set("tuning")

    def held_out_set(self) -> list[ModelCase]:
        """``validate.samples`` models drawn from ``validate.seed``, never tuned on."""
        return self._set("held-out")

    def summary(self) -> str:
        b = self.block
        corners = 2 ** len(b.dists) if b.corners else 0
        return (f"{b.tuning_size()} tuning models (nominal, {corners} corners, {b.samples} samples; seed {b.seed}), "
                f"{b.validate_samples} held-out models (seed {b.validate_seed})")

    def dimensions(self) -> str:
        """Each uncertain parameter and its distribution, for the report."""
        return ", ".join(f"{d.name}: {d.text()}" for d in self.block.dists)


def uncertainty_from_spec(spec: Any, plant: Any, delay_n: int, period_s: float,
                          key: str = "objective.uncertainty") -> MujocoUncertainty | None:
    """The block on ``plant`` (None when absent); ``ValueError`` naming the key (the shared block's checks)."""
    if spec is None:
        return None
    have = {**plant.named_parameters(), "sensor.delay_s": delay_n * period_s, "sensor.noise_scale": 1.0}
    kind = SimpleNamespace(key="mujoco", uncertain=lambda _spec: have)
    block = block_from_spec(spec, kind, {}, period_s)
    for d in block.dists:
        if d.name == "sensor.delay_s" and d.low < 0:
            raise ValueError(f"{key}.parameters.sensor.delay_s: a delay is >= 0 s; the range reaches {d.low:g} s")
    return MujocoUncertainty(block, int(delay_n), float(period_s))


def over_models(costs: np.ndarray, agg: Aggregation | None) -> float:
    """The cost of a candidate over its models by ``objective.aggregate``'s ``models`` form (mean by default)."""
    costs = np.asarray(costs, dtype=float)
    if costs.size == 0:
        return math.nan
    return combine(costs[:, None], np.ones(1), agg or Aggregation())[0]

