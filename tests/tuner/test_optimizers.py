"""Optimisers: documented quality thresholds, bookkeeping, state round trips, no global RNG use."""

import pickle

import numpy as np
import pytest

from objectives.functions import rastrigin, rosenbrock
from tuner.optimizers import CMAES, DE, OPTIMIZERS, PSO, OptionError, RandomSearch

BUDGET = 6000  # evaluations, 10-D problems


def _minimise(opt, f, lo, hi):
    while not opt.done:
        u = opt.ask()
        assert u.min() >= 0 and u.max() <= 1
        opt.tell(u, f(lo + u * (hi - lo)))
    return opt


def _median_best(cls, f, lo, hi, seeds=5, **kw):
    out = []
    for s in range(seeds):
        o = cls(10, np.random.default_rng(s), max_evals=BUDGET, **kw)
        out.append(_minimise(o, f, lo, hi).best_f)
    return float(np.median(out))


# Documented thresholds (median over 5 seeds, 6000 evaluations, 10-D). Random search for reference
# reaches about 1.4e4 on Rosenbrock and 68 on Rastrigin with the same budget.
PSO_LINEAR = dict(population=30, generations=BUDGET // 30, inertia="linear", c1=1.5, c2=1.5)


@pytest.mark.parametrize("name, cls, kw, f, lo, hi, threshold", [
    ("pso-rosenbrock", PSO, PSO_LINEAR, rosenbrock, -5, 10, 10.0),
    ("pso-rastrigin", PSO, PSO_LINEAR, rastrigin, -5.12, 5.12, 15.0),
    ("pso-constriction-rosenbrock", PSO, dict(population=30, generations=None, constriction=True,
                                              c1=2.05, c2=2.05), rosenbrock, -5, 10, 10.0),
    ("cmaes-rosenbrock", CMAES, dict(generations=None), rosenbrock, -5, 10, 1e-2),
    ("cmaes-rastrigin", CMAES, dict(generations=None), rastrigin, -5.12, 5.12, 20.0),
    ("de-rosenbrock", DE, dict(population=30, generations=None), rosenbrock, -5, 10, 12.0),
    ("de-rastrigin", DE, dict(population=30, generations=None, CR=0.1, F=0.5), rastrigin, -5.12, 5.12, 1.0),
])
@pytest.mark.slow
def test_reaches_documented_threshold(name, cls, kw, f, lo, hi, threshold):
    assert _median_best(cls, f, lo, hi, **kw) < threshold


def test_methods_beat_random_search():
    rand = _median_best(RandomSearch, rosenbrock, -5, 10, seeds=3, population=30, generations=None)
    pso = _median_best(PSO, rosenbrock, -5, 10, seeds=3, population=30, generations=None)
    assert pso < rand / 10


@pytest.mark.parametrize("method", sorted(OPTIMIZERS))
def test_bookkeeping_and_global_rng_untouched(method):
    state = np.random.get_state()[1].copy()
    o = OPTIMIZERS[method](4, np.random.default_rng(0), population=8, generations=5)
    history = []
    while not o.done:
        u = o.ask()
        assert np.array_equal(u, o.ask()), "ask() must be idempotent until tell()"
        f = rosenbrock(u * 4 - 2)
        o.tell(u, f)
        history.append(o.best_f)
    assert o.generation == 5 and o.n_evals == 40
    assert all(b2 <= b1 for b1, b2 in zip(history, history[1:])), "best never worsens"
    assert o.stop_reason == "5 generations"
    assert np.array_equal(np.random.get_state()[1], state), f"{method} touched numpy's global RNG"


@pytest.mark.parametrize("method", sorted(OPTIMIZERS))
def test_state_round_trip_continues_identically(method):
    def drive(o, n):
        out = []
        for _ in range(n):
            u = o.ask()
            f = rastrigin(u * 10 - 5)
            o.tell(u, f)
            out.append(u)
        return out

    a = OPTIMIZERS[method](3, np.random.default_rng(42), population=6, generations=20)
    drive(a, 4)
    blob = pickle.dumps(a.state())
    rest_a = drive(a, 6)
    b = OPTIMIZERS[method].from_state(pickle.loads(blob))
    rest_b = drive(b, 6)
    for ua, ub in zip(rest_a, rest_b):
        assert np.array_equal(ua, ub)
    assert a.best_f == b.best_f


@pytest.mark.parametrize("method", sorted(OPTIMIZERS))
def test_state_of_another_class_or_untagged_is_refused(method):
    """A state names its class; ``from_state`` of another optimiser, or of a state without the tag,
    raises ValueError instead of building a half-filled object. The keys survive in order."""
    state = OPTIMIZERS[method](3, np.random.default_rng(1), population=6, generations=5).state()
    assert list(state)[-1] == "class" and state["class"] == OPTIMIZERS[method].__name__
    other = next(cls for name, cls in sorted(OPTIMIZERS.items()) if cls.__name__ != state["class"])
    with pytest.raises(ValueError, match=f"not of a {other.__name__}"):
        other.from_state(state)
    with pytest.raises(ValueError, match="not of a"):
        OPTIMIZERS[method].from_state({k: v for k, v in state.items() if k != "class"})
    again = OPTIMIZERS[method].from_state(state).state()
    assert list(again) == list(state)


def test_pso_update_matches_equation():
    """One step of the seed PSO equation computed by hand with the same random numbers."""
    rng = np.random.default_rng(5)
    o = PSO(2, rng, population=3, generations=10, v_max=1.0, boundary="clip")
    x = o.ask()
    v0 = o.V.copy()
    f = np.array([3.0, 1.0, 2.0])
    twin = np.random.Generator(np.random.PCG64())
    twin.bit_generator.state = o.rng.bit_generator.state
    o.tell(x, f)
    r1, r2 = twin.random((3, 2)), twin.random((3, 2))
    g = x[1]
    v = 0.9 * v0 + 0.5 * r1 * (x - x) + 1.5 * r2 * (g - x)
    assert np.allclose(o.X, np.clip(x + v, 0, 1))


def test_pso_constriction_coefficient_and_ring():
    o = PSO(2, np.random.default_rng(0), population=10, generations=3, constriction=True, c1=2.05, c2=2.05,
            topology="ring")
    assert o.chi == pytest.approx(0.7298, abs=1e-4)
    o.Pf = np.arange(10, dtype=float)[::-1].copy()  # particle 9 is best
    nb = o._neighbourhood_best()
    assert np.array_equal(nb[0], o.P[9]) and np.array_equal(nb[8], o.P[9]) and np.array_equal(nb[4], o.P[5])


@pytest.mark.parametrize("boundary", ["reflect", "clip", "random"])
def test_pso_boundaries_keep_particles_inside(boundary):
    o = PSO(5, np.random.default_rng(1), population=20, generations=30, v_max=1.0, w=1.2, boundary=boundary)
    _minimise(o, lambda x: np.sum((x - 1.7) ** 2, axis=1), 0, 1)  # optimum outside the cube
    assert o.best_x.max() <= 1.0


def test_warm_start_and_stopping_rules():
    x0 = np.full(3, 0.5)
    o = PSO(3, np.random.default_rng(0), population=5, generations=50, x0=x0, target=1e-3)
    assert np.array_equal(o.ask()[0], x0)
    _minimise(o, lambda x: np.sum((x - 0.5) ** 2, axis=1), 0, 1)
    assert o.generation == 1 and "target" in o.stop_reason
    o = DE(3, np.random.default_rng(0), population=6, generations=None, patience=3)
    _minimise(o, lambda x: np.ones(len(x)), 0, 1)
    assert o.generation == 1 + 3 and "no improvement" in o.stop_reason


def test_bad_options_are_rejected():
    rng = np.random.default_rng(0)
    with pytest.raises(OptionError, match="topology"):
        PSO(2, rng, topology="star")
    with pytest.raises(OptionError, match="c1 \\+ c2 > 4"):
        PSO(2, rng, constriction=True)
    with pytest.raises(OptionError, match=r"population must be in \[4, inf\) candidates, got 3"):
        DE(2, rng, population=3)
    with pytest.raises(OptionError, match="sigma0"):
        CMAES(2, rng, sigma0=2.0)
    assert "inertia" in PSO.option_names() and "max_evals" in PSO.option_names()


@pytest.mark.parametrize("method", sorted(OPTIMIZERS))
@pytest.mark.parametrize("max_evals", [0, -3])
def test_a_budget_below_one_evaluation_is_refused(method, max_evals):
    """``max_evals`` < 1 used to 'finish' a run after no evaluation with best fitness inf."""
    with pytest.raises(OptionError, match=rf"max_evals must be in \[1, inf\) evaluations, got {max_evals}"):
        OPTIMIZERS[method](dim=2, rng=np.random.default_rng(0), population=4, max_evals=max_evals)


@pytest.mark.parametrize("method", sorted(OPTIMIZERS))
def test_population_is_computed_once_without_building(method):
    """``population_for`` (what the config and the worker rule use) is the population the constructor runs with,
    for every method, dimension and budget, and the options are checked against the declaration alone."""
    cls = OPTIMIZERS[method]
    for dim in (2, 3, 5, 9, 14):
        for opts in ({"generations": 3}, {"generations": 40}, {"generations": None, "max_evals": 400},
                     {"generations": 5, "population": 6}, {"generations": None, "max_evals": 5000},
                     {"generations": 2, "popsize": 7} if "popsize" in cls.option_names() else {"generations": 2}):
            cls.check_options(opts, dim)
            built = cls(dim, np.random.default_rng(0), **opts)
            assert cls.population_for(dim, opts) == built.population == len(built.ask()) or method == "trust_region" \
                and cls.population_for(dim, opts) == built.population, (method, dim, opts)


def test_options_are_checked_against_the_declaration_with_the_key_named():
    with pytest.raises(OptionError, match="unknown option for de") as e:
        DE.check_options({"w": 0.5})
    assert e.value.key == "w"
    with pytest.raises(OptionError) as e:
        PSO.check_options({"v_max": 0.0})
    assert e.value.key == "v_max" and e.value.message == "must be in (0, 1] fraction of the range, got 0.0"
    with pytest.raises(OptionError) as e:   # a combination rule, under the preset's coefficients
        PSO.check_options({"preset": "clerc", "c1": 1.0})
    assert e.value.key == "constriction" and "c1 + c2 > 4, got 3.05" in e.value.message
    PSO.check_options({"preset": "clerc"})   # the preset's own c1 = c2 = 2.05 are fine
    with pytest.raises(OptionError, match="at least 2 free parameters"):   # only once the dimension is known
        CMAES.check_options({"sigma0": 0.2}, dim=1)
    CMAES.check_options({"sigma0": 0.2})
    assert DE.check_options({"F": 1, "population": 8}) == {"F": 1.0, "population": 8}
