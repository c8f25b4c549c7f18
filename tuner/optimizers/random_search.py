"""Random search: the baseline every method must beat. Uniform or Latin-hypercube batches."""

from __future__ import annotations

from typing import Any, Literal

import numpy as np

from tuner.optimizers.base import Optimizer, declare, latin_hypercube
from tuner.params import Param

__all__ = ["RandomSearch"]


class RandomSearch(Optimizer):
    """Independent batches of ``population`` points (options in :attr:`RandomSearch.options`)."""

    name = "random"
    options = declare("random", (
        Param("sampler", "uniform", choices=("uniform", "lhs"),
              doc="Uniform in the cube, or a Latin hypercube per batch (better coverage for small batches)."),
    ))

    def __init__(self, dim: int, rng: np.random.Generator, *,
                 sampler: Literal["uniform", "lhs"] = "uniform", **common: Any):
        self.check_options(dict(sampler=sampler, **common), dim)
        super().__init__(dim, rng, **common)
        self.sampler = sampler
        self.batch: np.ndarray | None = None

    def ask(self) -> np.ndarray:
        if self.batch is None:
            n, d = self.population, self.dim
            self.batch = latin_hypercube(self.rng, n, d) if self.sampler == "lhs" else self.rng.random((n, d))
            if self.x0 is not None and self.generation == 0:
                self.batch[0] = self.x0
        return self.batch.copy()

    def _tell(self, x: np.ndarray, f: np.ndarray) -> None:
        self.batch = None
