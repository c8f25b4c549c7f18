"""``realtime``, the causal filter on VQF's design, a unit: ``filter.py`` (the class, its declaration ``DECL``, its
C port), ``kernel.py`` (the numba kernel and its coefficient and state layouts), ``port.c`` (the C port, which
indexes by the same layouts). No population kernel: evaluated serially (``loky``)."""

from objectives.attitude.filters.realtime.filter import DECL, Realtime

__all__ = ["Realtime", "DECL"]
