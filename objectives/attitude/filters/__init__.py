"""Attitude filters by YAML name. Modules are imported on first use (numba compile is lazy too)."""

from __future__ import annotations

import importlib

from objectives.attitude.filters.base import AttitudeFilter, FilterResult

__all__ = ["AttitudeFilter", "FilterResult", "FILTERS", "get_filter", "filter_names"]

#: YAML name -> "module:Class"
FILTERS: dict[str, str] = {
    "kf1d": "objectives.attitude.filters.kf1d:KF1D",
    "akf1d": "objectives.attitude.filters.kf1d:AKF1D",
    "mahony1d": "objectives.attitude.filters.kf1d:Mahony1D",
    "madgwick1d": "objectives.attitude.filters.kf1d:Madgwick1D",
    "ekf": "objectives.attitude.filters.ekf:EKF",
    "faekf": "objectives.attitude.filters.ekf:FAEKF",
    "madgwick": "objectives.attitude.filters.madgwick:Madgwick",
    "mahony": "objectives.attitude.filters.mahony:Mahony",
    "lcf": "objectives.attitude.filters.complementary:LCF",
    "ncf": "objectives.attitude.filters.complementary:NCF",
    "ccf": "objectives.attitude.filters.complementary:CCF",
    "qukf": "objectives.attitude.filters.ukf:QUKF",
    "qraukf": "objectives.attitude.filters.ukf:QRAUKF",
    "vqf": "objectives.attitude.filters.vqf:VQF",
    "realtime": "objectives.attitude.filters.realtime:Realtime",
    "imu_tools_madgwick": "objectives.attitude.filters.imu_tools_madgwick:ImuToolsMadgwick",
    "valenti": "objectives.attitude.filters.valenti:Valenti",
}


def filter_names() -> list[str]:
    return sorted(FILTERS)


def get_filter(name: str) -> type[AttitudeFilter]:
    """The filter class registered under ``name``; ValueError lists the known names."""
    if name not in FILTERS:
        raise ValueError(f"unknown filter {name!r}; known: {filter_names()}")
    module, cls = FILTERS[name].split(":")
    return getattr(importlib.import_module(module), cls)
