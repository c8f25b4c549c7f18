"""CMA-ES through the ``cma`` package's ask/tell (Hansen), in the unit cube.

We do not re-implement CMA-ES. The wrapper gives pycma our random generator (``randn`` option) and
``seed=nan`` so that pycma never touches NumPy's global RNG, and pickles the whole strategy for
resume (the generator travels inside it).
"""

from __future__ import annotations

import io
import math
import pickle
from contextlib import redirect_stdout
from typing import Any

import numpy as np

from tuner.optimizers.base import Optimizer, OptionError

__all__ = ["CMAES"]


class _Randn:
    """Picklable ``randn(lam, n)`` drawing from a numpy Generator."""

    def __init__(self, rng: np.random.Generator):
        self.rng = rng

    def __call__(self, *shape: int) -> np.ndarray:
        return self.rng.standard_normal(shape)


class CMAES(Optimizer):
    """Covariance matrix adaptation evolution strategy (pycma).

    Parameters
    ----------
    sigma0 : float
        Initial step size in unit-cube coordinates (default 0.3: about a third of each range).
    popsize : int, optional
        Alias of ``population``; pycma's default is ``4 + floor(3 ln dim)``.
    x0 : array, optional
        Initial mean (default: the centre of the cube).
    cma_options : dict
        Further pycma options (``tolfun``, ``CMA_active``, ...), passed through verbatim.
    """

    name = "cmaes"

    def __init__(self, dim: int, rng: np.random.Generator, *, sigma0: float = 0.3,
                 popsize: int | None = None, cma_options: dict | None = None, **common: Any):
        if popsize is not None:
            common["population"] = popsize
        common.setdefault("population", 4 + int(3 * math.log(max(int(dim), 1))))
        super().__init__(dim, rng, **common)
        if not 0 < sigma0 <= 1:
            raise OptionError(f"sigma0 must be in (0, 1] (unit-cube coordinates), got {sigma0}")
        if self.dim < 2:
            raise OptionError("cmaes needs at least 2 free parameters (pycma does not do 1-D); use pso or de")
        import cma

        opts = {
            "bounds": [0.0, 1.0],
            "popsize": self.population,
            "seed": np.nan,
            "randn": _Randn(rng),
            "verbose": -9,
            "verb_disp": 0,
            "verb_log": 0,
            "verb_filenameprefix": "",
            "maxiter": np.inf,
            "maxfevals": np.inf,
        }
        opts.update(cma_options or {})
        x0 = self.x0 if self.x0 is not None else np.full(self.dim, 0.5)
        with redirect_stdout(io.StringIO()):
            self.es = cma.CMAEvolutionStrategy(list(x0), float(sigma0), opts)
        self.sigma0 = float(sigma0)
        self._asked: np.ndarray | None = None
        self._raw: list | None = None

    def ask(self) -> np.ndarray:
        if self._asked is None:
            self._raw = self.es.ask()
            self._asked = np.clip(np.array(self._raw, dtype=float), 0.0, 1.0)
        return self._asked.copy()

    def _tell(self, x: np.ndarray, f: np.ndarray) -> None:
        if self._asked is None or x.shape != self._asked.shape:
            raise ValueError("CMAES.tell expects the population returned by the last ask()")
        # pycma wants the very solution objects it generated (its boundary handler tracks them)
        fin = np.where(np.isfinite(f), f, np.finfo(float).max / 1e10)
        self.es.tell(self._raw, list(fin))
        self._asked = None
        self._raw = None

    def _method_done(self) -> str:
        stop = {k: v for k, v in self.es.stop().items() if k not in ("maxiter", "maxfevals")}
        return ", ".join(f"cma:{k}" for k in stop) if stop else ""

    def state(self) -> dict[str, Any]:
        # the strategy (with our generator inside) as bytes; the generator is kept in sync with it
        fields = {k: v for k, v in self.__dict__.items() if k not in ("rng", "es")}
        return self._tagged(fields, es=pickle.dumps(self.es))

    @classmethod
    def from_state(cls, state: dict[str, Any]) -> CMAES:
        obj = cls._bare(state)
        obj.es = pickle.loads(state["es"])
        obj.rng = obj.es.opts["randn"].rng
        return obj
