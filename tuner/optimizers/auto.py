"""``method: auto``: picks an optimiser from the dimension and the evaluation budget, then delegates to it.

Rules (measured on the benchmark test functions and problems; numbers in
``benchmarks/results/auto_rules.md``), with ``budget`` in evaluations (``max_evals``, else
``population x generations``, with population 20 when none is given):

0. ``budget < 100 dim`` and either ``dim <= 4`` or ``dim <= 10`` with ``budget >= 30 dim``: ``trust_region``
   (a quadratic model after a Latin hypercube).
   With few parameters and about a hundred evaluations a fitted quadratic finds the basin's bottom
   sooner than a population adapts: at 120 evaluations it beats ``cmaes`` on 11 of the 12 test-function
   rows in 2-4-D (10 seeds; 4-D Rastrigin is lost since the valley moves of ``trust_region``), is the
   best of ours on madgwick_broad and ekf_bench6dof (38.5 and 30.5 evaluations to 1 %; ``cmaes`` 70 and
   38.5), on mahony_broad within half an evaluation of the best (17.5; ``cmaes`` 37), and the only
   method, ours or a peer's, that reaches 1 % on pid_wmp in half the seeds (6 of 10 in 113 evaluations;
   ``cmaes`` 1 of 10). In 5-10-D at 30-100 evaluations per dimension (below that rule 1 applies) it beats
   ``cmaes`` on 18 of 20 test-function rows (6-D and 10-D at 60 and 90 per dimension, 8-D at 60, 5-D at
   300 evaluations; 10 seeds) and finds the FAEKF's better basin in 7 of 10 seeds at 540 evaluations
   (``cmaes`` 1 of 10); on the 15-D fuzzy_wmp at 900 the two tie (0.0487 / 0.0486), hence the cap at 10-D.
   At 150 per dimension ``cmaes`` wins 6 of 8 rows, hence the upper limit.
1. ``dim == 1`` or ``budget < 30 dim``: ``pso`` with ``preset: lowbudget`` (pycma does not do 1-D;
   with under 30 evaluations per dimension CMA-ES has barely adapted: at 120 evaluations in 10-D the
   PSO preset wins on all four test functions, in 5-D on all four).
2. ``budget >= 300 dim``: ``cmaes_restart`` (IPOP). By then a single CMA-ES run has usually
   converged, and on multimodal landscapes only a restart with a larger population still gains.
3. otherwise: ``cmaes`` (100-300 evaluations per dimension, or more than 10 parameters from 30 per
   dimension): at 150 per dimension it is ahead of ``trust_region`` on 6 of 8 test-function rows in 6-D
   and 10-D.

The choice depends only on ``dim`` and the budget, so it is deterministic and a replayed run picks the
same method. :meth:`Auto.describe` names it (printed when the run starts; :attr:`Auto.chosen` holds the
method name). The chosen method receives every common option (``target``, ``patience``, ``x0``, ...);
for the CMA-ES family and ``trust_region`` a ``generations`` budget is converted to
``max_evals = population x generations`` (their population is their own default, pycma's
``4 + floor(3 ln dim)`` or ``max(3, dim + 1)``, unless ``population`` is given), so the evaluation budget is
the same whichever method is picked.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from tuner.optimizers.base import AT_LEAST_1, Optimizer, OptionError, WrapperOptimizer, declare
from tuner.optimizers.cmaes import CMAES
from tuner.optimizers.cmaes_restart import CMAESRestart
from tuner.optimizers.pso import PSO
from tuner.optimizers.trust_region import TrustRegion
from tuner.params import Param

__all__ = ["Auto", "choose"]

#: evaluations per dimension from which restarts pay off (auto_rules.md)
RESTART_EVALS_PER_DIM = 300
#: evaluations per dimension below which the low-budget PSO beats CMA-ES (auto_rules.md)
PSO_EVALS_PER_DIM = 30
#: largest dimension and evaluations per dimension below which the quadratic-model trust region wins at any
#: budget; up to TRUST_REGION_MID_DIM it also wins from PSO_EVALS_PER_DIM evaluations per dimension on
TRUST_REGION_MAX_DIM = 4
TRUST_REGION_MID_DIM = 10
TRUST_REGION_EVALS_PER_DIM = 100
#: swarm size of the measured low-budget PSO when no population is given
PSO_POPULATION = 12


def choose(dim: int, budget: int | None) -> str:
    """The method ``auto`` picks for ``dim`` free parameters and ``budget`` evaluations (``None``: unbounded)."""
    if budget is not None and budget < TRUST_REGION_EVALS_PER_DIM * dim and (
            dim <= TRUST_REGION_MAX_DIM or (dim <= TRUST_REGION_MID_DIM and budget >= PSO_EVALS_PER_DIM * dim)):
        return "trust_region"
    if dim < 2 or (budget is not None and budget < PSO_EVALS_PER_DIM * dim):
        return "pso"
    if budget is None or budget >= RESTART_EVALS_PER_DIM * dim:
        return "cmaes_restart"
    return "cmaes"


class Auto(WrapperOptimizer):
    """Delegating optimiser; see the module docstring for the rules. Its options are those every optimiser
    has (:attr:`Auto.options`); together they set the budget the rules look at."""

    name = "auto"
    options = declare("auto", (
        Param("population", None, unit="candidates", allowed=AT_LEAST_1, integer=True, nullable=True, kind="number",
              doc="Candidates per generation of the chosen method; unset: that method's own (12 for the "
                  "low-budget PSO), with the budget counted at 20 per generation."),
    ))

    @staticmethod
    def _budget(options: Any) -> int | None:
        """The evaluation budget the rules look at (``max_evals``, else population (20 unset) x generations)."""
        gens = options.get("generations", 50)
        if options.get("max_evals") is not None:
            return int(options["max_evals"])
        pop = options.get("population")
        return None if gens is None else (20 if pop is None else int(pop)) * int(gens)

    @classmethod
    def _combination(cls, v: dict[str, Any], dim: int | None, given: set[str]) -> None:
        super()._combination(v, dim, given)
        if dim is not None and choose(int(dim), cls._budget(v)) == "pso" and v["generations"] is None \
                and v["max_evals"] is None:
            raise OptionError("auto picks pso in 1-D, which needs a generations or max_evals budget")

    @classmethod
    def population_for(cls, dim: int, options: Any) -> int:
        pop = options.get("population")
        if pop is not None:
            return int(pop)
        chosen = choose(int(dim), cls._budget(options))
        if chosen == "pso":
            return PSO_POPULATION
        return {"trust_region": TrustRegion, "cmaes": CMAES, "cmaes_restart": CMAESRestart}[chosen].population_for(
            dim, {})

    def __init__(self, dim: int, rng: np.random.Generator, **common: Any):
        pop_given = common.get("population")
        self.check_options(common, dim)
        super().__init__(dim, rng, **common)
        gens, max_evals = self.generations, self.max_evals
        budget = max_evals if max_evals is not None else (None if gens is None else self.population * gens)
        self.chosen = choose(self.dim, budget)
        inner_common = dict(common)
        if self.chosen == "pso":
            if gens is None and max_evals is None:
                raise OptionError("auto picks pso in 1-D, which needs a generations or max_evals budget")
            if pop_given is None:  # the measured swarm, same evaluation budget
                inner_common["population"] = PSO_POPULATION
                if gens is not None:
                    inner_common["generations"] = max(1, budget // PSO_POPULATION)
            self.inner: Optimizer = PSO(self.dim, rng, preset="lowbudget", **inner_common)
        elif self.chosen == "trust_region":
            if pop_given is None:  # its own batch size, the same number of evaluations
                inner_common.pop("population", None)
                if gens is not None:
                    inner_common["generations"] = None
                    inner_common["max_evals"] = budget
            self.inner = TrustRegion(self.dim, rng, **inner_common)
        else:
            if gens is not None:  # the same number of evaluations, whatever CMA-ES's population
                inner_common["generations"] = None
                inner_common["max_evals"] = budget
            if pop_given is None:
                inner_common.pop("population", None)
            cls = CMAESRestart if self.chosen == "cmaes_restart" else CMAES
            self.inner = cls(self.dim, rng, **inner_common)
        # the outer object mirrors the inner budget so the engine's progress line is right
        self.generations, self.max_evals = self.inner.generations, self.inner.max_evals
        self.population = self.inner.population

    def describe(self) -> str:
        inner = self.inner.describe() if hasattr(self.inner, "describe") else self.chosen
        if self.chosen == "pso":
            inner = "pso(preset lowbudget)"
        return f"auto -> {inner}"

    def ask(self) -> np.ndarray:
        x = self.inner.ask()
        self.population = len(x)
        return x

    def _tell(self, x: np.ndarray, f: np.ndarray) -> None:
        self.inner.tell(x, f)

    def _method_done(self) -> str:
        return self.inner._method_done()

    @classmethod
    def _inner_class(cls, fields: dict[str, Any]) -> type:
        classes = {"pso": PSO, "cmaes": CMAES, "cmaes_restart": CMAESRestart, "trust_region": TrustRegion}
        return classes[fields["chosen"]]
