"""The quaternion UKFs QUKF and QRAUKF (Chiella et al. 2019), a unit: ``filters.py`` (the classes and their
declarations; the equations and deviations), ``kernel.py`` (the numba kernel and its layouts, with the profile),
``mean.py`` and ``scalar.py`` (its inlined helpers), ``robust.py`` (the robust blocks' driver),
``population.py`` (the population kernel). No C port."""

from objectives.attitude.filters.ukf.filters import QRAUKF, QUKF, run_setup, run_ukf, ukf_setup

__all__ = ["QUKF", "QRAUKF", "run_ukf", "ukf_setup", "run_setup"]
