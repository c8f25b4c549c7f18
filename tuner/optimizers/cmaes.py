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

from tuner.optimizers.base import Optimizer, OptionError, declare
from tuner.params import Interval, Param

__all__ = ["CMAES", "CMARules", "CMA_OPTIONS", "cma_population"]

#: the options pycma-based methods share (the population is pycma's own default unless given)
CMA_OPTIONS = (
    Param("sigma0", 0.3, unit="unit cube", allowed=Interval(0.0, 1.0, low_open=True),
          doc="Initial step size in unit-cube coordinates (0.3: about a third of each range)."),
    Param("popsize", None, unit="candidates", allowed=Interval(2.0), integer=True, nullable=True, kind="number",
          doc="Alias of population."),
    Param("cma_options", None, kind="any", nullable=True,
          doc="Further pycma options (tolfun, CMA_active, ...), a mapping passed through verbatim."),
    Param("population", None, unit="candidates", allowed=Interval(2.0), integer=True, nullable=True, kind="number",
          doc="Candidates per generation (pycma needs >= 2); unset: pycma's 4 + floor(3 ln dim)."),
)


def cma_population(dim: int, options: Any) -> int:
    """The population of a pycma-based method: ``popsize``, else ``population``, else pycma's default."""
    for key in ("popsize", "population"):
        if options.get(key) is not None:
            return int(options[key])
    return 4 + int(3 * math.log(max(int(dim), 1)))


def check_cma(v: dict[str, Any], dim: int | None) -> None:
    """The rules pycma adds: a mapping of options, at least 2 free parameters."""
    if v["cma_options"] is not None and not isinstance(v["cma_options"], dict):
        raise OptionError(f"must be a mapping of pycma options, got {v['cma_options']!r}", "cma_options")
    if v["cma_options"]:
        import cma

        bad = sorted(k for k in v["cma_options"] if k not in cma.CMAOptions())
        if bad:
            raise OptionError(f"not pycma options: {bad} (cma.CMAOptions() lists them)", "cma_options")
    if dim is not None and int(dim) < 2:
        raise OptionError("cmaes needs at least 2 free parameters (pycma does not do 1-D); use pso or de")


class _Randn:
    """Picklable ``randn(lam, n)`` drawing from a numpy Generator."""

    def __init__(self, rng: np.random.Generator):
        self.rng = rng

    def __call__(self, *shape: int) -> np.ndarray:
        return self.rng.standard_normal(shape)


class CMARules:
    """The option rules and population of the pycma-based optimisers (:class:`CMAES`, ``CMAESRestart``)."""

    @classmethod
    def _combination(cls, v: dict[str, Any], dim: int | None, given: set[str]) -> None:
        super()._combination(v, dim, given)  # type: ignore[misc]
        check_cma(v, dim)

    @classmethod
    def population_for(cls, dim: int, options: Any) -> int:
        return cma_population(dim, options)


class CMAES(CMARules, Optimizer):
    """Covariance matrix adaptation evolution strategy (pycma); options in :attr:`CMAES.options`.

    ``x0`` is the initial mean (default: the centre of the cube).
    """

    name = "cmaes"
    options = declare("cmaes", CMA_OPTIONS)

    def __init__(self, dim: int, rng: np.random.Generator, *, sigma0: float = 0.3,
                 popsize: int | None = None, cma_options: dict | None = None, **common: Any):
        self.check_options(dict(sigma0=sigma0, popsize=popsize, cma_options=cma_options, **common), dim)
        common["population"] = self.population_for(dim, {**common, "popsize": popsize})
        super().__init__(dim, rng, **common)
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
