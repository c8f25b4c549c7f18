"""Mahony's filter, a unit: ``filter.py`` (the class, its declaration ``DECL``, its C port), ``kernel.py`` (the
numba kernel and its coefficient layout), ``population.py`` (the population kernel), ``port.c`` (the C port)."""

from objectives.attitude.filters.mahony.filter import DECL, Mahony, mahony_batch

__all__ = ["Mahony", "mahony_batch", "DECL"]
