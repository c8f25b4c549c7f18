"""The wheeled mobile pendulum as a ``Plant`` (:mod:`objectives.control.plants.base`) and its registered kind.

The plant is the 8-state model of :mod:`.model` (thesis eq. 2.12) with its parameters (Table 2.1,
:class:`~.params.WMPParams`) and sensors (Table 1.1, :class:`~.params.SensorParams`), stepped with the
singular-perturbation RK4 of :mod:`.model` (``n_sub`` substeps per controller period ``Ts_s``). Its
closed loop is not the generic kernel: the sensor suite and the Kalman filter of eq. 2.20 run inside the
pendulum's own loop kernel (:func:`.model._simulate`), so its kind has a family of its own, ``wmp``
(:mod:`.loop`), and its controllers are the ``wmp`` family of :data:`objectives.control.controllers.CONTROLLERS`.

YAML: ``plant: wmp`` (the default), its settings at the objective's top level (``plant_params``,
``sensors``, ``n_sub``, ``fall_limit_deg``: :mod:`.loop`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, ClassVar

import numpy as np
import scipy.linalg

from objectives.control.plants.base import PlantKind
from objectives.control.plants.wmp.model import _step
from objectives.control.plants.wmp.params import SensorParams, WMPParams

__all__ = ["WMPPlant", "wmp_plant", "WMP"]


@dataclass(frozen=True)
class WMPPlant:
    """The pendulum: state (theta1, theta2, theta3, their rates, I1, I2), inputs (u1, u2) V, outputs
    (nu, theta3, omega3, xi, I_A) of eq. 2.12, at the controller period ``sensors.Ts_s``."""

    linear: ClassVar[bool] = False
    params: WMPParams
    sensors: SensorParams
    n_sub: int = 10
    model: str = "wmp"
    delay_n: int = 0
    output: int = 0
    inner_output: int = -1
    x0: np.ndarray = field(default_factory=lambda: np.zeros(8))

    @property
    def period_s(self) -> float:
        return float(self.sensors.Ts_s)

    @property
    def n_states(self) -> int:
        return 8

    @property
    def n_inputs(self) -> int:
        return 2

    @property
    def n_outputs(self) -> int:
        return 5

    def reset(self) -> None:
        """Nothing to reset: every run starts from ``x0``."""

    def advance(self, x: np.ndarray, u: np.ndarray) -> np.ndarray:
        """The state one controller period after ``x`` with the voltages ``u`` (V) held (``n_sub`` steps of
        the model's integrator, without the loop's saturation or quantisation)."""
        x = np.array(x, dtype=float)
        scratch = np.zeros(27)
        c = self.params.coeffs()
        h = self.period_s / self.n_sub
        for _ in range(self.n_sub):
            _step(x, float(u[0]), float(u[1]), h, c, scratch)
        return x

    def outputs(self, x: np.ndarray) -> np.ndarray:
        """The true outputs of eq. 2.12 at state ``x``."""
        r, d = self.params.r_m, self.params.d_m
        return np.array([0.5 * r * (x[3] + x[4]), x[2], x[5], r * (x[4] - x[3]) / d, 0.5 * (x[6] + x[7])])

    def run_loop(self, sig, cp, opt, y, u, x):
        """Not the generic kernel: the pendulum's loop holds its sensors (:mod:`.loop`)."""
        raise ValueError("the pendulum runs in its own loop (plant: wmp, objectives.control.plants.wmp.loop)")

    def design_model(self) -> tuple[np.ndarray, np.ndarray]:
        """``(Ad, Bd)``: the linearisation at rest (eq. 2.17) with a zero-order hold at ``Ts_s``."""
        from objectives.control.plants.wmp.controllers.lqr import linearize

        a, b = linearize(self.params)
        n, m = b.shape
        blk = np.zeros((n + m, n + m))
        blk[:n, :n], blk[:n, n:] = a * self.period_s, b * self.period_s
        e = scipy.linalg.expm(blk)
        return e[:n, :n], e[:n, n:]

    def tracked_row(self) -> np.ndarray:
        """The speed nu = r (dtheta1 + dtheta2) / 2 as a state combination."""
        row = np.zeros(8)
        row[3] = row[4] = 0.5 * self.params.r_m
        return row

    def named_parameters(self) -> dict[str, float]:
        """Table 2.1's parameters (:class:`~.params.WMPParams`), the ones a robustness study perturbs."""
        return {k: float(v) for k, v in self.params.to_dict().items() if isinstance(v, (int, float))
                and math.isfinite(float(v))}


def wmp_plant(plant_params: Any, sensors: Any, n_sub: int) -> WMPPlant:
    """The pendulum of ``plant_params`` (:class:`~.params.WMPParams` overrides) and ``sensors``
    (:class:`~.params.SensorParams` overrides); ``ValueError`` naming the bad key."""
    return WMPPlant(WMPParams.from_dict(plant_params), SensorParams.from_dict(sensors), int(n_sub))


#: the registered kind (objectives.control.plants.PLANTS): by name, its own loop family
WMP = PlantKind("wmp", frozenset(), wmp_plant, "wmp",
                "the thesis's wheeled mobile pendulum (plant: wmp; controllers pid, lqr, lqg, flc, ...)", named=True)
