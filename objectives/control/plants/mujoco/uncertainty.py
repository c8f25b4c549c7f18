"""Uncertain MuJoCo plants: a seeded set of perturbed models to tune on and a separate one to validate on.

YAML (``objective:``)::

    uncertainty:
      parameters:                       # one entry = one uncertain dimension
        body.pole.mass: {scale: [0.8, 1.2]}        # a factor on the model's value, uniform
        body.*.mass: {scale: [0.8, 1.2]}           # a pattern: every match scaled by the same factor
        joint.hinge.damping: {range: [0.0, 0.02]}  # a value, uniform
        actuator.push.gain: {normal_scale: 0.05}   # a factor 1 + 0.05 N(0, 1)
        geom.floor.friction: {normal: {mean: 0.8, std: 0.1}}
        sensor.delay_s: {range: [0.0, 0.01]}       # the measurement delay (s, rounded to periods)
        sensor.noise_std: {scale: [0.5, 2.0]}      # a factor on every measured signal's noise
      corners: true          # the 2^k corners of the dimensions (uniform ones at their bounds, normal ones at
                             # mean +- 2 std), for k <= 8
      samples: 8             # random models besides the nominal one and the corners
      held_out: 100          # validation models, drawn apart from the tuning ones
      seed: 0
      aggregate: mean        # the cost over the models: mean | worst | cvar (the mean of the worst cvar_alpha)
      cvar_alpha: 0.2

The names are the plant's named parameters (:mod:`.parameters`: ``body.<b>.mass``, ``body.<b>.ixx``,
``joint.<j>.damping``, ``joint.<j>.frictionloss``, ``actuator.<a>.gain``, ...; a pattern uses ``*`` and
``?``) and the measurement's ``sensor.delay_s`` and ``sensor.noise_std``. The tuning set is the nominal model,
then the corners, then the samples (size stated in the report); the held-out set is ``held_out`` models
drawn from ``SeedSequence([seed, 1])`` (the samples from ``[seed, 0]``), so no held-out model was tuned on.
A perturbed plant is the plant's model with the parameter values set
(:meth:`.model.MujocoPlant.with_parameters`, equal to building the spec with them in ``parameters``).
"""

from __future__ import annotations

import fnmatch
import itertools
import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from objectives.control.plants.scenario import _num

__all__ = ["Dimension", "ModelCase", "Uncertainty", "uncertainty_from_spec", "aggregate", "SENSOR_PARAMETERS"]

SENSOR_PARAMETERS = ("sensor.delay_s", "sensor.noise_std")
_KEYS = {"parameters", "corners", "samples", "held_out", "seed", "aggregate", "cvar_alpha"}
_MAX_CORNER_DIMS = 8


@dataclass(frozen=True)
class Dimension:
    """One uncertain dimension: the parameters it sets, how (``scale``/``normal_scale``: a factor;
    ``range``/``normal``: a value) and its bounds (uniform) or mean and std (normal)."""

    key: str
    names: tuple[str, ...]
    how: str
    a: float
    b: float

    @property
    def factor(self) -> bool:
        return self.how in ("scale", "normal_scale")

    def corners(self) -> tuple[float, float]:
        if self.how in ("scale", "range"):
            return self.a, self.b
        return self.a - 2.0 * self.b, self.a + 2.0 * self.b

    def draw(self, rng: np.random.Generator) -> float:
        if self.how in ("scale", "range"):
            return float(rng.uniform(self.a, self.b))
        return float(self.a + self.b * rng.standard_normal())


@dataclass(frozen=True)
class ModelCase:
    """One model of a set: its label, the plant parameter values, the delay (periods) and the noise factor."""

    label: str
    values: dict[str, float]
    delay_n: int
    noise_scale: float


@dataclass(frozen=True)
class Uncertainty:
    """The validated block (module docstring) and the nominal values it perturbs."""

    dims: tuple[Dimension, ...]
    corners: bool
    samples: int
    held_out: int
    seed: int
    how: str
    cvar_alpha: float
    nominal: dict[str, float]
    delay_n: int
    period_s: float

    def _case(self, label: str, point: tuple[float, ...]) -> ModelCase:
        values: dict[str, float] = {}
        delay, noise = self.delay_n, 1.0
        for dim, v in zip(self.dims, point):
            for name in dim.names:
                if name == "sensor.delay_s":
                    delay = max(0, int(round((v * self.delay_n * self.period_s if dim.factor else v) / self.period_s)))
                elif name == "sensor.noise_std":
                    noise = max(0.0, v)
                else:
                    values[name] = self.nominal[name] * v if dim.factor else v
        values = {k: max(v, 1e-12 if k.rsplit(".", 1)[1] in ("mass", "ixx", "iyy", "izz", "gain") else 0.0)
                  for k, v in values.items()}
        return ModelCase(label, values, delay, noise)

    def nominal_case(self) -> ModelCase:
        return ModelCase("nominal", {}, self.delay_n, 1.0)

    def tuning_set(self) -> list[ModelCase]:
        """The nominal model, the corners (when asked and k <= 8), the seeded samples."""
        cases = [self.nominal_case()]
        if self.corners and self.dims and len(self.dims) <= _MAX_CORNER_DIMS:
            for i, pt in enumerate(itertools.product(*(d.corners() for d in self.dims))):
                cases.append(self._case(f"corner {i + 1}", pt))
        rng = np.random.default_rng(np.random.SeedSequence([self.seed, 0]))
        for i in range(self.samples):
            cases.append(self._case(f"sample {i + 1}", tuple(d.draw(rng) for d in self.dims)))
        return cases

    def held_out_set(self) -> list[ModelCase]:
        """``held_out`` models drawn from their own seed stream."""
        rng = np.random.default_rng(np.random.SeedSequence([self.seed, 1]))
        return [self._case(f"held-out {i + 1}", tuple(d.draw(rng) for d in self.dims)) for i in range(self.held_out)]

    def summary(self) -> str:
        n = len(self.tuning_set())
        corners = (2 ** len(self.dims)) if self.corners and self.dims and len(self.dims) <= _MAX_CORNER_DIMS else 0
        return (f"{n} tuning models (nominal, {corners} corners, {self.samples} samples; seed {self.seed}), "
                f"{self.held_out} held-out models; cost over models: {self.how}"
                + (f" (alpha {self.cvar_alpha:g})" if self.how == "cvar" else ""))


def _dimension(key: str, pattern: str, dist: Any, known: list[str]) -> Dimension:
    if not isinstance(pattern, str):
        raise ValueError(f"{key}: parameter names are strings, got {pattern!r}")
    names = tuple(n for n in known if fnmatch.fnmatchcase(n, pattern))
    if not names:
        sample = [n for n in known if n.split(".")[0] == pattern.split(".")[0]][:10] or known[:10]
        raise ValueError(f"{key}.{pattern}: matches no parameter of the plant; e.g. {sample} (names are "
                         "<element>.<name>.<field> of named bodies, joints, actuators and geoms, and sensor.delay_s, "
                         "sensor.noise_std)")
    if not isinstance(dist, Mapping) or len(dist) != 1:
        raise ValueError(f"{key}.{pattern}: give one of scale: [lo, hi], range: [lo, hi], normal: {{mean, std}}, "
                         f"normal_scale: std; got {dist!r}")
    (how, v), = dist.items()
    k = f"{key}.{pattern}.{how}"
    if "sensor.noise_std" in names and how not in ("scale", "normal_scale"):
        raise ValueError(f"{k}: sensor.noise_std takes a factor on the sensor section's noise (scale or "
                         "normal_scale)")
    if how in ("scale", "range"):
        if not (isinstance(v, list) and len(v) == 2):
            raise ValueError(f"{k}: expected [low, high], got {v!r}")
        lo, hi = _num(f"{k}[0]", v[0], 0.0), _num(f"{k}[1]", v[1], 0.0)
        if not lo <= hi:
            raise ValueError(f"{k}: low {lo:g} must not exceed high {hi:g}")
        if how == "scale" and lo <= 0 and any(n.rsplit(".", 1)[1] in ("mass", "ixx", "iyy", "izz", "gain")
                                              for n in names):
            raise ValueError(f"{k}: a factor on a mass, inertia or gain must be > 0, got low {lo:g}")
        return Dimension(pattern, names, how, lo, hi)
    if how == "normal":
        if not (isinstance(v, Mapping) and set(v) == {"mean", "std"}):
            raise ValueError(f"{k}: expected {{mean, std}}, got {v!r}")
        return Dimension(pattern, names, how, _num(f"{k}.mean", v["mean"], 0.0), _num(f"{k}.std", v["std"], 0.0))
    if how == "normal_scale":
        return Dimension(pattern, names, how, 1.0, _num(k, v, 0.0))
    raise ValueError(f"{key}.{pattern}: unknown distribution {how!r}; allowed: scale, range, normal, normal_scale")


def uncertainty_from_spec(spec: Any, plant: Any, delay_n: int, period_s: float,
                          key: str = "objective.uncertainty") -> Uncertainty | None:
    """The validated block on ``plant`` (None when absent); ``ValueError`` naming the key."""
    if spec is None:
        return None
    if not isinstance(spec, Mapping):
        raise ValueError(f"{key}: expected a mapping (parameters, corners, samples, held_out, seed, aggregate)")
    unknown = sorted(set(spec) - _KEYS)
    if unknown:
        raise ValueError(f"{key}.{unknown[0]}: unknown key; allowed: {sorted(_KEYS)}")
    params = spec.get("parameters")
    if not isinstance(params, Mapping) or not params:
        raise ValueError(f"{key}.parameters: expected a mapping {{parameter: distribution}} with one entry at least")
    nominal = plant.named_parameters()
    known = [*nominal, *SENSOR_PARAMETERS]
    dims = tuple(_dimension(f"{key}.parameters", p, d, known) for p, d in params.items())
    ints = {}
    for name, default, lo in (("samples", 8, 0), ("held_out", 100, 0), ("seed", 0, 0)):
        v = spec.get(name, default)
        if isinstance(v, bool) or not isinstance(v, int) or v < lo:
            raise ValueError(f"{key}.{name}: must be an integer >= {lo}, got {v!r}")
        ints[name] = v
    corners = spec.get("corners", True)
    if not isinstance(corners, bool):
        raise ValueError(f"{key}.corners: true or false, got {corners!r}")
    how = spec.get("aggregate", "mean")
    if how not in ("mean", "worst", "cvar"):
        raise ValueError(f"{key}.aggregate: one of mean, worst, cvar, got {how!r}")
    alpha = _num(f"{key}.cvar_alpha", spec.get("cvar_alpha", 0.2), 0.0, strict=True)
    if alpha > 1:
        raise ValueError(f"{key}.cvar_alpha: a fraction in (0, 1], got {alpha:g}")
    return Uncertainty(dims, corners, ints["samples"], ints["held_out"], ints["seed"], how, alpha, nominal,
                       delay_n, period_s)


def aggregate(costs: np.ndarray, how: str, alpha: float = 0.2) -> float:
    """The cost over models: their mean, the worst, or the CVaR (mean of the worst ``ceil(alpha n)``)."""
    costs = np.asarray(costs, dtype=float)
    if how == "worst":
        return float(np.max(costs))
    if how == "cvar":
        k = max(1, math.ceil(alpha * costs.size))
        return float(np.mean(np.sort(costs)[-k:]))
    return float(np.mean(costs))
