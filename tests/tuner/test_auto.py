"""``method: auto``: deterministic choice by dimension and budget, same evaluation budget, replay."""

import numpy as np
import pytest

from objectives.functions import FUNCTIONS
from tuner.optimizers import OPTIMIZERS, Auto
from tuner.optimizers.auto import choose


@pytest.mark.parametrize("dim, budget, expected", [
    (1, 100, "pso"), (1, None, "pso"), (5, 120, "pso"), (5, 149, "pso"), (10, 299, "pso"),
    (1, 99, "trust_region"), (2, 120, "trust_region"), (4, 399, "trust_region"), (4, 400, "cmaes"),
    (2, 40, "trust_region"), (2, None, "cmaes_restart"),
    (5, 150, "trust_region"), (5, 499, "trust_region"), (5, 500, "cmaes"), (10, 300, "trust_region"),
    (10, 999, "trust_region"), (10, 1000, "cmaes"), (11, 330, "cmaes"), (15, 900, "cmaes"),
    (5, 1499, "cmaes"), (5, 1500, "cmaes_restart"),
    (10, 6000, "cmaes_restart"), (3, None, "cmaes_restart"),
])
def test_rules(dim, budget, expected):
    assert choose(dim, budget) == expected


def test_budget_is_population_times_generations_and_is_kept():
    o = Auto(5, np.random.default_rng(0), population=20, generations=30)  # 600 evaluations
    assert o.chosen == "cmaes" and o.max_evals == 600 and o.generations is None
    assert o.describe() == "auto -> cmaes"
    n = 0
    while not o.done:
        u = o.ask()
        o.tell(u, np.sum(u * u, axis=1))
        n += len(u)
    assert 600 <= n < 600 + o.population
    assert OPTIMIZERS["auto"] is Auto


def test_one_dimension_uses_lowbudget_pso_with_the_given_swarm():
    o = Auto(1, np.random.default_rng(0), population=8, generations=15)  # 120 evaluations: 1-D, over 100
    assert o.chosen == "pso" and o.inner.preset == "lowbudget" and len(o.ask()) == 8 and o.generations == 15
    assert "lowbudget" in o.describe()
    o = Auto(10, np.random.default_rng(0), generations=6)  # 20 x 6 = 120 evaluations, as 12 x 10
    assert o.chosen == "pso" and o.population == 12 and o.generations == 10


def test_large_budget_restarts_and_reports_it():
    o = Auto(10, np.random.default_rng(0), generations=None, max_evals=6000)
    assert o.chosen == "cmaes_restart" and o.describe().startswith("auto -> cmaes_restart(ipop")


def test_auto_matches_the_chosen_method_run_directly():
    from tuner.optimizers import CMAES

    f, (lo, hi) = FUNCTIONS["rastrigin"]
    a = Auto(5, np.random.default_rng(4), max_evals=600, generations=None)
    b = CMAES(5, np.random.default_rng(4), max_evals=600, generations=None)
    for _ in range(10):
        ua, ub = a.ask(), b.ask()
        np.testing.assert_array_equal(ua, ub)
        a.tell(ua, f(lo + ua * (hi - lo)))
        b.tell(ub, f(lo + ub * (hi - lo)))


def test_state_round_trip_continues_identically():
    def step(o, n):
        for _ in range(n):
            u = o.ask()
            o.tell(u, np.sum((u - 0.2) ** 2, axis=1))
        return o

    a = step(Auto(3, np.random.default_rng(2), max_evals=5000, generations=None), 40)
    b = step(Auto.from_state(step(Auto(3, np.random.default_rng(2), max_evals=5000, generations=None), 20).state()), 20)
    np.testing.assert_array_equal(a.ask(), b.ask())
    assert a.best_f == b.best_f and a.describe() == b.describe()


def test_auto_at_least_as_good_as_plain_cmaes_at_low_budget_in_10d():
    # 120 evaluations in 10-D (median of 5 seeds): low-budget PSO 1.26 on the sphere, CMA-ES 4.64
    from tuner.optimizers import CMAES

    f, (lo, hi) = FUNCTIONS["sphere"]

    def med(cls):
        out = []
        for s in range(5):
            o = cls(10, np.random.default_rng(s), generations=None, max_evals=120)
            while not o.done:
                u = o.ask()
                o.tell(u, f(lo + u * (hi - lo)))
            out.append(o.best_f)
        return float(np.median(out))

    assert med(Auto) < 0.5 * med(CMAES)


def test_few_parameters_small_budget_use_the_trust_region_with_the_same_budget():
    from tuner.optimizers import TrustRegion

    f, (lo, hi) = FUNCTIONS["rosenbrock"]
    a = Auto(2, np.random.default_rng(9), generations=6)  # 20 x 6 = 120 evaluations in 2-D, its own batches
    b = TrustRegion(2, np.random.default_rng(9), max_evals=120, generations=None)
    assert a.chosen == "trust_region" and a.max_evals == 120 and a.generations is None
    assert a.describe().startswith("auto -> trust_region(")
    n = 0
    while not a.done:
        ua, ub = a.ask(), b.ask()
        np.testing.assert_array_equal(ua, ub)
        a.tell(ua, f(lo + ua * (hi - lo)))
        b.tell(ub, f(lo + ub * (hi - lo)))
        n += len(ua)
    assert n == 120 and b.done and a.best_f == b.best_f


def test_trust_region_state_round_trip_through_auto():
    def step(o, n):
        for _ in range(n):
            u = o.ask()
            o.tell(u, np.sum((u - 0.3) ** 2, axis=1) + np.sin(9 * u[:, 0]))
        return o

    a = step(Auto(3, np.random.default_rng(2), max_evals=250, generations=None), 12)
    b = step(Auto.from_state(step(Auto(3, np.random.default_rng(2), max_evals=250, generations=None), 5).state()), 7)
    assert a.chosen == b.chosen == "trust_region"
    np.testing.assert_array_equal(a.ask(), b.ask())
    assert a.best_f == b.best_f and a.describe() == b.describe()
