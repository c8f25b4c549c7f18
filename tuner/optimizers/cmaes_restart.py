"""CMA-ES with restarts: IPOP (Auger & Hansen 2005) and BIPOP (Hansen 2009), around our ``cmaes`` wrapper.

A restart begins when pycma's own termination criteria fire (``tolfun``, ``tolx``, ``tolstagnation``,
...), with ``tolx = 1e-4`` (unit-cube coordinates, a ten-thousandth of each range) unless ``cma_options``
says otherwise: pycma's default ``tolx = 1e-11`` spends about half of a 6000-evaluation budget refining
the first local minimum of the 10-D Rastrigin function. The run as a whole stops only on the common
budget rules (``generations``, ``max_evals``, ``target``, ``patience``) or when ``max_restarts``
restarts have ended too.

IPOP
    Every restart doubles the population (``lambda_k = lambda_0 2^k``) and starts from a uniformly drawn
    mean with the initial ``sigma0``.
BIPOP
    Two interlaced regimes. The *large* one is IPOP (doubling population, ``sigma0``); the *small*
    one draws ``lambda_s = floor(lambda_0 (lambda_l / (2 lambda_0))^(u^2))`` and
    ``sigma_s = sigma0 10^(-2u)``, ``u ~ U(0, 1)``, where ``lambda_l`` is the last large population. After
    each run the regime that has used fewer evaluations so far goes next (Hansen 2009, section 2).

Budget accounting: ``generations`` counts every ``ask``/``tell`` across all restarts (a generation of a
doubled population counts as one generation), so with varying populations prefer ``max_evals``. ``ask``
always returns the current population, whose size is :attr:`population`. Every random number comes from
the generator passed in, so replaying ``tell`` from the history reproduces the run exactly.
"""

from __future__ import annotations

from typing import Any, Literal

import numpy as np

from tuner.optimizers.base import WrapperOptimizer, declare
from tuner.optimizers.cmaes import CMA_OPTIONS, CMAES, CMARules
from tuner.params import NONNEG, Param

__all__ = ["CMAESRestart"]


class CMAESRestart(CMARules, WrapperOptimizer):
    """CMA-ES restarted with an increasing (IPOP) or bi-population (BIPOP) schedule (options in
    :attr:`CMAESRestart.options`; ``population`` and ``popsize`` are those of the first run, ``cma_options``
    apply to every run, whose ``popsize`` the schedule sets, with ``tolx: 1e-4`` unless given)."""

    name = "cmaes_restart"
    options = declare("cmaes_restart", (
        Param("strategy", "ipop", choices=("ipop", "bipop"), doc="Restart schedule (module docstring)."),
        Param("max_restarts", 9, unit="restarts", allowed=NONNEG, integer=True,
              doc="Restarts after the first run (9: up to 2^9 times the initial population)."),
        *CMA_OPTIONS,
    ))

    def __init__(self, dim: int, rng: np.random.Generator, *, strategy: Literal["ipop", "bipop"] = "ipop",
                 max_restarts: int = 9, sigma0: float = 0.3, popsize: int | None = None,
                 cma_options: dict | None = None, **common: Any):
        self.check_options(dict(strategy=strategy, max_restarts=max_restarts, sigma0=sigma0, popsize=popsize,
                                cma_options=cma_options, **common), dim)
        common["population"] = self.population_for(dim, {**common, "popsize": popsize})
        super().__init__(dim, rng, **common)
        self.strategy = strategy
        self.max_restarts = int(max_restarts)
        self.sigma0 = float(sigma0)
        self.cma_options = {"tolx": 1e-4, **(cma_options or {})}
        self.pop0 = self.population
        self.restarts = 0
        self.n_large = 0  # large-regime restarts so far (IPOP: every restart)
        self.evals_large = 0  # BIPOP budgets: the first run counts as large
        self.evals_small = 0
        self.regime = "large"
        self.runs: list[dict[str, Any]] = []  # one entry per run: population, sigma0, regime, evaluations
        self.inner = self._new_run(self.pop0, self.sigma0, self.x0)

    def _new_run(self, pop: int, sigma0: float, x0: np.ndarray | None) -> CMAES:
        self.population = int(pop)
        self.runs.append({"population": int(pop), "sigma0": float(sigma0), "regime": self.regime, "evals": 0})
        # the inner strategy has no budget of its own (the outer object stops the run)
        return CMAES(self.dim, self.rng, sigma0=sigma0, population=pop, generations=None, max_evals=2**62,
                     x0=x0, cma_options=self.cma_options)

    def _restart(self) -> None:
        self.restarts += 1
        x0 = self.rng.random(self.dim)
        if self.strategy == "ipop" or self.evals_large <= self.evals_small:
            self.regime = "large"
            self.n_large += 1
            pop, sigma = self.pop0 * 2 ** self.n_large, self.sigma0
        else:
            self.regime = "small"
            u = float(self.rng.random())
            large = self.pop0 * 2 ** self.n_large
            pop = max(2, int(self.pop0 * (0.5 * large / self.pop0) ** (u * u)))
            sigma = self.sigma0 * 10.0 ** (-2.0 * u)
        self.inner = self._new_run(pop, sigma, x0)

    def describe(self) -> str:
        """The method as a progress line shows it (strategy, restarts so far, current population)."""
        return f"cmaes_restart({self.strategy}, restart {self.restarts}, population {self.population})"

    def ask(self) -> np.ndarray:
        if self.inner._method_done() and self.restarts < self.max_restarts:
            self._restart()
        return self.inner.ask()

    def _tell(self, x: np.ndarray, f: np.ndarray) -> None:
        self.inner.tell(x, f)
        self.runs[-1]["evals"] += len(f)
        if self.regime == "large":
            self.evals_large += len(f)
        else:
            self.evals_small += len(f)

    def _method_done(self) -> str:
        if self.restarts >= self.max_restarts:
            stop = self.inner._method_done()
            return f"{self.restarts} restarts, then {stop}" if stop else ""
        return ""

    @classmethod
    def _inner_class(cls, fields: dict[str, Any]) -> type:
        return CMAES
