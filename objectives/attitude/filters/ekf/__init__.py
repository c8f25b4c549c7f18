"""The quaternion EKF and the FAEKF, a unit: ``filter.py`` (the EKF class, its declaration, its C port),
``faekf.py`` (the fuzzy-adaptive class), ``fuzzy.py`` (the FAEKF's fuzzy scaling and its kernel), ``kernel.py``
(the EKF's numba kernel and its layouts), ``population.py`` (both population kernels), ``port.c`` (the EKF's C
port). The equations and deviations from the paper: :mod:`objectives.attitude.filters.ekf.filter`."""

from objectives.attitude.filters.base import gravity_in_units
from objectives.attitude.filters.ekf.faekf import FAEKF, Disturbances
from objectives.attitude.filters.ekf.filter import EKF
from objectives.attitude.filters.ekf.fuzzy import (
    FUZZY_DEFAULTS,
    FUZZY_INPUTS,
    FUZZY_SETS,
    K_DEFAULTS,
    SEARCHED_K,
    faekf_rules,
    fuzzy_scale,
    rule_consequent_index,
)
from objectives.attitude.filters.ekf.kernel import ekf_kernel

__all__ = [
    "EKF", "FAEKF", "FUZZY_DEFAULTS", "K_DEFAULTS", "SEARCHED_K", "FUZZY_INPUTS", "FUZZY_SETS",
    "ekf_kernel", "fuzzy_scale", "gravity_in_units", "rule_consequent_index", "Disturbances", "faekf_rules",
]
