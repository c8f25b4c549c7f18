"""Random search: the baseline every method must beat. Uniform or Latin-hypercube batches."""

from __future__ import annotations

from typing import Any, Literal

import numpy as np

from tuner.optimizers.base import Optimizer, OptionError, latin_hypercube

__all__ = ["RandomSearch"]


class RandomSearch(Optimizer):
    """Independent batches of ``population`` points.

    Parameters
    ----------
    sampler : {"uniform", "lhs"}
        Uniform in the cube, or a Latin hypercube per batch (better coverage for small batches).
    """

    name = "random"

    def __init__(self, dim: int, rng: np.random.Generator, *,
                 sampler: Literal["uniform", "lhs"] = "uniform", **common: Any):
        super().__init__(dim, rng, **common)
        if sampler not in ("uniform", "lhs"):
            raise OptionError(f"sampler must be 'uniform' or 'lhs', got {sampler!r}")
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
