"""A set of plant models the loop scores a controller on, and their margins.

:func:`build_models` builds each model of a draw (:func:`objectives.control.plants.uncertainty.draw_models`)
with the plant kind's own builder on the perturbed spec. :class:`ModelSet` keeps the plants, their
labels and perturbed values and, for LTI models, each model's frequency response at the loop's
frequency grid (computed once), so a candidate's margins on every model cost one product per model
(:meth:`ModelSet.margins`): the loop ``L_m = sum_j G_j P_mj`` (:mod:`.analysis`), its closed-loop poles
checked first (an unstable loop has Ms = inf and margins -inf), then Ms, gain and phase margin.
"""

from __future__ import annotations

import math
import pathlib
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from objectives.control.plants.analysis import (
    closed_loop_poles,
    exact_loop,
    frequency_grid,
    margins,
    plant_response,
)
from objectives.control.plants.uncertainty import ModelDraw, set_path

__all__ = ["ModelSet", "build_models", "MARGIN_KEYS"]

#: the margin metrics of one model
MARGIN_KEYS = ("ms", "gm_db", "pm_deg", "cl_pole_max")


@dataclass
class ModelSet:
    """Plants (the first of a tuning set is the nominal one), their labels and perturbed values.

    Attributes
    ----------
    name : str
        ``tuning`` or ``held-out``.
    plants : list of Plant
    labels : list of str
        ``nominal``, ``corner +-+``, ``sample 3``.
    values : list of dict
        The perturbed parameters of each model (empty for the nominal plant without uncertainty).
    seed : int or None
        The seed its samples were drawn from.
    """

    name: str
    plants: list[Any]
    labels: list[str]
    values: list[dict[str, float]] = field(default_factory=list)
    seed: int | None = None

    def __post_init__(self) -> None:
        self.linear = all(p.linear for p in self.plants)
        self._omega: np.ndarray | None = None
        self._pr: list[dict[str, np.ndarray]] = []

    def __len__(self) -> int:
        return len(self.plants)

    def describe(self) -> str:
        """``"9 models (nominal, 8 corners)"``: the size and the make-up of the set."""
        if len(self) == 1:
            return "the nominal plant"
        kinds = {"nominal": 0, "corner": 0, "sample": 0}
        for lab in self.labels:
            kinds[lab.split(" ")[0]] += 1
        parts = [f"{v} {k}{'s' if v > 1 and k != 'nominal' else ''}" for k, v in kinds.items() if v]
        seed = f", seed {self.seed}" if self.seed is not None and kinds["sample"] else ""
        return f"{len(self)} model{'s' if len(self) > 1 else ''} ({', '.join(parts)}{seed})"

    def responses(self, states: bool) -> tuple[np.ndarray, list[dict[str, np.ndarray]]]:
        """The frequency grid and each model's plant response ("outputs", and "states" if asked)."""
        if self._omega is None:
            self._omega = frequency_grid(self.plants[0].period_s)
            self._pr = [{"outputs": plant_response(p, self._omega, False)} for p in self.plants]
        if states and "states" not in self._pr[0]:
            for p, pr in zip(self.plants, self._pr):
                pr["states"] = plant_response(p, self._omega, True)
        return self._omega, self._pr

    def loops(self, ctrl: Any, cp: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(omega, L)``: the loop transfer function of every model, (M, len(omega)) complex."""
        omega, prs = self.responses(states=ctrl.name == "lqr_sf")
        z = np.exp(1j * omega * self.plants[0].period_s)
        g = ctrl.feedback(cp, self.plants[0], z)
        key = "states" if "states" in g else "outputs"
        return omega, np.array([np.sum(g[key] * pr[key], axis=1) for pr in prs])

    def margins(self, ctrl: Any, cp: np.ndarray) -> list[dict[str, float]]:
        """Ms, gain and phase margin, their crossover frequencies and the largest closed-loop pole of each
        model (:data:`MARGIN_KEYS` and ``wc_rad_s``, ``w180_rad_s``), the grid's extrema and crossings refined
        on the exact loop response (:func:`.analysis.margins`), so Ms is the true peak to far below 1e-6."""
        omega, L = self.loops(ctrl, cp)
        out = []
        for p, lm in zip(self.plants, L):
            pole = float(np.max(np.abs(closed_loop_poles(ctrl.kind, cp, p))))
            if not pole < 1.0:
                out.append({"ms": math.inf, "gm_db": -math.inf, "pm_deg": -math.inf, "cl_pole_max": pole,
                            "wc_rad_s": math.nan, "w180_rad_s": math.nan})
            else:
                exact = exact_loop(ctrl, cp, p, ctrl.name == "lqr_sf")
                out.append({**margins(lm, omega, exact, math.pi / p.period_s), "cl_pole_max": pole})
        return out


def build_models(kind: Any, spec: dict[str, Any], draw: ModelDraw, period_s: float, base_dir: pathlib.Path | None,
                 name: str, seed: int | None, nominal: Any = None) -> ModelSet:
    """The plants of ``draw``, each built by ``kind.build`` on ``spec`` with its values set
    (``kind.perturb``, else :func:`~objectives.control.plants.uncertainty.set_path`); the label ``nominal``
    reuses ``nominal`` when given. A model that cannot be built, or whose sizes differ from the first,
    is a ``ValueError`` naming it and its values."""
    perturb = kind.perturb or set_path
    plants = []
    for label, values in zip(draw.labels, draw.values):
        if label == "nominal" and nominal is not None:
            plants.append(nominal)
            continue
        shown = ", ".join(f"{k} = {v:.6g}" for k, v in values.items())
        try:
            plant = kind.build(perturb(spec, values), period_s, base_dir, "objective.plant")
        except ValueError as exc:
            raise ValueError(f"objective.uncertainty: the {name} set's model '{label}' ({shown}) cannot be built: "
                             f"{exc}") from None
        if plants and (plant.n_states, plant.n_inputs, plant.n_outputs) != \
                (plants[0].n_states, plants[0].n_inputs, plants[0].n_outputs):
            raise ValueError(f"objective.uncertainty: the {name} set's model '{label}' ({shown}) has other sizes "
                             "than the nominal plant (a coefficient that changes the model's order?)")
        plants.append(plant)
    return ModelSet(name, plants, list(draw.labels), [dict(v) for v in draw.values], seed)
