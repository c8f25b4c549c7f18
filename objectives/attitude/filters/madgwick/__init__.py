"""Madgwick's filter, a unit: ``filter.py`` (the class, its declaration ``DECL``, its C port), ``kernel.py`` (the
numba kernel and its coefficient layout), ``population.py`` (the population kernel), ``port.c`` (the C port)."""

from objectives.attitude.filters.madgwick.filter import DECL, Madgwick, madgwick_batch
from objectives.attitude.filters.madgwick.kernel import VARIANTS

__all__ = ["Madgwick", "madgwick_batch", "VARIANTS", "DECL"]
