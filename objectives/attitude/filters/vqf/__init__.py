"""The VQF filter (Laidig & Seel 2023) through the external ``vqf`` package, a unit: ``filter.py`` (the class and
its declaration). No numba kernel of its own (hence no layout, population kernel or C port): the ``realtime``
unit is this project's filter on VQF's design."""

from objectives.attitude.filters.vqf.filter import INSTALL_HINT, VQF, VQF_PARAMS

__all__ = ["VQF", "VQF_PARAMS", "INSTALL_HINT"]
