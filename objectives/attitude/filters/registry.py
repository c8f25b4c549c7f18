"""The filter registry: YAML name -> the class that runs it, each unit imported on first use.

This is the one list of filters. A filter family is a unit (a package under ``objectives/attitude/filters/``
holding its class and declaration, its kernel with its layouts, its C port and its population kernel); its
classes enter here by one line each. Everything that works on every filter (the objective, the C export and
its test, the population batch, ``tuner describe``, the benchmarks) reaches them through :func:`get_filter`
and :func:`filter_names`, and what a class offers through the class itself (``c_port``, ``population``).

A leaf module: it imports no filter, so a filter module may use it (``AttitudeFilter.from_run``) without an
import circle through the package face.
"""

from __future__ import annotations

import importlib
from typing import Any

__all__ = ["FILTERS", "get_filter", "filter_names", "register_filter", "unregister_filter"]

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
    """Every registered YAML name, sorted."""
    return sorted(FILTERS)


def get_filter(name: str) -> type[Any]:
    """The filter class registered under ``name``; ValueError lists the known names."""
    if name not in FILTERS:
        raise ValueError(f"unknown filter {name!r}; known: {filter_names()}")
    module, cls = FILTERS[name].split(":")
    return getattr(importlib.import_module(module), cls)


def register_filter(name: str, target: str) -> None:
    """Register the class ``target`` (``"module:Class"``, imported on first use) under the YAML name ``name``.

    A filter outside this package (a plugin, a test's toy filter) enters the registry this way and is then a
    filter like the others: configs name it, the C export renders its ``c_port``, the population batch runs its
    ``population``. A worker process finds a filter by its name, so a plugin registers in every process (where
    its module is imported). ValueError for a name already registered (naming both targets) or a malformed target.
    """
    if not (isinstance(name, str) and name.isidentifier() and name.islower()):
        raise ValueError(f"filter name must be a lower-case identifier, got {name!r}")
    if not (isinstance(target, str) and target.count(":") == 1 and all(target.split(":"))):
        raise ValueError(f"filter {name!r}: target must be 'module:Class', got {target!r}")
    if name in FILTERS:
        raise ValueError(f"filter {name!r} is registered already ({FILTERS[name]}); not registering {target}")
    FILTERS[name] = target


def unregister_filter(name: str) -> None:
    """Remove ``name`` from the registry (a test's toy filter after the test); KeyError if it is not there."""
    del FILTERS[name]
