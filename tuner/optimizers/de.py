"""Differential evolution, DE/rand/1/bin (Storn & Price 1997), in ask/tell form.

Generation 0 asks for the initial population; every later generation asks for one trial vector per
member::

    v_i = x_r1 + F (x_r2 - x_r3)          r1, r2, r3 distinct and != i
    u_ij = v_ij if rand < CR or j == j_rand else x_ij
    x_i <- u_i if f(u_i) <= f(x_i)

Updating is deferred (the whole population is replaced after the generation, like scipy's
``updating='deferred'``), so parallel evaluation changes nothing.
"""

from __future__ import annotations

from typing import Any, Literal

import numpy as np

from tuner.optimizers.base import COMMON, Optimizer, OptionError, declare, latin_hypercube
from tuner.params import NONNEG, UNIT_CLOSED, Interval, Param

__all__ = ["DE"]


class DE(Optimizer):
    """DE/rand/1/bin (options in :attr:`DE.options`, ``tuner describe de``)."""

    name = "de"
    options = declare("de", (
        Param("F", 0.7, unit="1", allowed=Interval(0.0, 2.0, low_open=True), doc="Differential weight."),
        Param("CR", 0.9, unit="1", allowed=UNIT_CLOSED, doc="Crossover probability."),
        Param("dither", 0.0, unit="1", allowed=NONNEG,
              doc="If > 0, F is drawn per generation uniformly in [F - dither, F + dither] (scipy's "
                  "mutation=(a, b)), which helps on multimodal problems; below F."),
        Param("init", "lhs", choices=("lhs", "uniform"), doc="Initial population: Latin hypercube or uniform."),
        Param("boundary", "reflect", choices=("reflect", "random", "clip"),
              doc="Trial components outside the cube are mirrored back, re-drawn uniformly, or clipped."),
        Param("population", 20, unit="candidates", allowed=Interval(4.0), integer=True,
              doc="Candidates per generation; >= 4 (rand/1 uses 3 others)."),
    ), COMMON)

    @classmethod
    def _combination(cls, v: dict[str, Any], dim: int | None, given: set[str]) -> None:
        super()._combination(v, dim, given)
        if v["F"] - v["dither"] <= 0:
            raise OptionError(f"must be < F, got dither={v['dither']}, F={v['F']}", "dither")

    def __init__(
        self,
        dim: int,
        rng: np.random.Generator,
        *,
        F: float = 0.7,
        CR: float = 0.9,
        dither: float = 0.0,
        init: Literal["lhs", "uniform"] = "lhs",
        boundary: Literal["reflect", "random", "clip"] = "reflect",
        **common: Any,
    ):
        self.check_options(dict(F=F, CR=CR, dither=dither, init=init, boundary=boundary, **common), dim)
        super().__init__(dim, rng, **common)
        self.F, self.CR, self.dither, self.boundary = float(F), float(CR), float(dither), boundary
        n, d = self.population, self.dim
        self.pop = latin_hypercube(rng, n, d) if init == "lhs" else rng.random((n, d))
        if self.x0 is not None:
            self.pop[0] = self.x0
        self.fit = np.full(n, np.inf)
        self.initialised = False
        self.trial: np.ndarray | None = None

    def ask(self) -> np.ndarray:
        if not self.initialised:
            return self.pop.copy()
        if self.trial is None:
            self.trial = self._make_trials()
        return self.trial.copy()

    def _make_trials(self) -> np.ndarray:
        n, d = self.pop.shape
        F = self.F if self.dither == 0 else self.rng.uniform(self.F - self.dither, self.F + self.dither)
        # three distinct partners != i, per member
        r = np.empty((n, 3), dtype=int)
        for i in range(n):
            choices = self.rng.choice(n - 1, size=3, replace=False)
            choices[choices >= i] += 1
            r[i] = choices
        v = self.pop[r[:, 0]] + F * (self.pop[r[:, 1]] - self.pop[r[:, 2]])
        cross = self.rng.random((n, d)) < self.CR
        cross[np.arange(n), self.rng.integers(0, d, n)] = True
        u = np.where(cross, v, self.pop)
        out = (u < 0) | (u > 1)
        if out.any():
            if self.boundary == "clip":
                u = np.clip(u, 0, 1)
            elif self.boundary == "reflect":
                y = np.mod(u, 2.0)
                u = np.where(y > 1.0, 2.0 - y, y)
            else:
                u[out] = self.rng.random(int(out.sum()))
        return u

    def _tell(self, x: np.ndarray, f: np.ndarray) -> None:
        if x.shape != self.pop.shape:
            raise ValueError(f"DE.tell expects the {self.pop.shape} population from ask(), got {x.shape}")
        if not self.initialised:
            self.pop, self.fit = x.copy(), f.copy()
            self.initialised = True
        else:
            better = f <= self.fit
            self.pop[better] = x[better]
            self.fit[better] = f[better]
        self.trial = None
