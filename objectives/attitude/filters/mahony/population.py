"""Mahony's population kernel (``backend: threads``): the shared driver
:func:`~objectives.attitude.filters._bias_population.population_lanes` around
:func:`~objectives.attitude.filters.mahony.kernel.mahony_kernel_inner`, compiled and cached as Mahony's own kernel."""

from __future__ import annotations

from numba import njit

from objectives.attitude.batch import Population
from objectives.attitude.filters._bias_filter import S
from objectives.attitude.filters._bias_population import population_lanes, run_population
from objectives.attitude.filters.mahony.kernel import C, mahony_kernel_inner
from objectives.jit import CACHE

__all__ = ["POPULATION"]


@njit(cache=CACHE, parallel=True)
def _population(data, pairs, lanes_, bufs, sums):
    """Mahony on every pair, error sums into ``sums[pair]`` (:func:`population_lanes`)."""
    population_lanes(mahony_kernel_inner, data, pairs, lanes_, bufs, sums)


#: Mahony's :class:`~objectives.attitude.batch.Population`
POPULATION = Population(run_population(_population), coef_len=C.LEN, state_len=S.MAG)
