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

from tuner.optimizers.base import Optimizer, OptionError, latin_hypercube

__all__ = ["DE"]


class DE(Optimizer):
    """DE/rand/1/bin.

    Parameters
    ----------
    F : float
        Differential weight in (0, 2]. Default 0.7.
    CR : float
        Crossover probability in [0, 1]. Default 0.9.
    dither : float
        If > 0, F is drawn per generation uniformly in ``[F - dither, F + dither]`` (scipy's
        ``mutation=(a, b)``), which helps on multimodal problems. Default 0.
    init : {"lhs", "uniform"}
        Initial population. Default Latin hypercube.
    boundary : {"reflect", "random", "clip"}
        Trial components outside the cube are mirrored back, re-drawn uniformly, or clipped.
    """

    name = "de"

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
        super().__init__(dim, rng, **common)
        if self.population < 4:
            raise OptionError(f"DE needs population >= 4 (rand/1 uses 3 others), got {self.population}")
        if not 0 < F <= 2:
            raise OptionError(f"F must be in (0, 2], got {F}")
        if not 0 <= CR <= 1:
            raise OptionError(f"CR must be in [0, 1], got {CR}")
        if dither < 0 or F - dither <= 0:
            raise OptionError(f"dither must be >= 0 and < F, got dither={dither}, F={F}")
        if init not in ("lhs", "uniform"):
            raise OptionError(f"init must be 'lhs' or 'uniform', got {init!r}")
        if boundary not in ("reflect", "random", "clip"):
            raise OptionError(f"boundary must be 'reflect', 'random' or 'clip', got {boundary!r}")
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
