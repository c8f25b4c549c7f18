"""The complementary filters LCF, NCF and CCF (Narkhede et al. 2021), a unit: ``filters.py`` (the classes, their
declarations, their one C port), ``kernel.py`` (the numba kernel with the robust blocks, its layouts),
``steps.py`` (the per-sample steps it inlines), ``port.c`` (the C port). No population kernel: evaluated
serially (``loky``)."""

from objectives.attitude.filters.complementary.filters import (
    ALPHA_MODES,
    CCF,
    LCF,
    NCF,
    alpha_at_rate,
    complementary_batch,
    tau_gains,
)
from objectives.attitude.filters.complementary.kernel import euler_zyx_from_quat, quat_from_euler_zyx

__all__ = ["LCF", "NCF", "CCF", "ALPHA_MODES", "complementary_batch", "quat_from_euler_zyx", "euler_zyx_from_quat",
           "tau_gains", "alpha_at_rate"]
