"""``realtime``, the causal filter on VQF's design, a unit: ``filter.py`` (the class, its declaration ``DECL``, its
C port), ``coefficients.py`` (the kernel's coefficient and state layouts, the coefficients and the start state),
``kernel.py`` (the numba kernel), ``port.c`` (the C port, which indexes by the same layouts). No population
kernel: evaluated serially (``loky``)."""

from objectives.attitude.filters.realtime.filter import DECL, Realtime

__all__ = ["Realtime", "DECL"]
