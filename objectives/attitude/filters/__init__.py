"""Attitude filters by YAML name. Each family is a unit, a package of its own (``madgwick/``, ``mahony/``,
``ekf/``, ``complementary/``, ``ukf/``, ``kf1d/``, ``realtime/``, ``vqf/``) holding its class and declaration,
its kernel with the kernel's layouts, its C port and its population kernel; the modules beside them are the
machinery the units share. The registry (:mod:`objectives.attitude.filters.registry`) names every class once;
units are imported on first use (numba compiles lazily too)."""

from __future__ import annotations

from objectives.attitude.filters.base import AttitudeFilter, FilterResult
from objectives.attitude.filters.registry import FILTERS, filter_names, get_filter, register_filter

__all__ = ["AttitudeFilter", "FilterResult", "FILTERS", "get_filter", "filter_names", "register_filter"]
