"""Optimisers by YAML name. All share the ask/tell interface of :class:`~tuner.optimizers.base.Optimizer`."""

from __future__ import annotations

from tuner.optimizers.auto import Auto
from tuner.optimizers.base import Optimizer, OptionError
from tuner.optimizers.cmaes import CMAES
from tuner.optimizers.cmaes_restart import CMAESRestart
from tuner.optimizers.de import DE
from tuner.optimizers.pso import PSO
from tuner.optimizers.random_search import RandomSearch
from tuner.optimizers.trust_region import TrustRegion

__all__ = ["Optimizer", "OptionError", "OPTIMIZERS", "get_optimizer", "PSO", "CMAES", "CMAESRestart", "DE", "Auto",
           "RandomSearch", "TrustRegion"]

OPTIMIZERS: dict[str, type[Optimizer]] = {}


def register(cls: type[Optimizer]) -> type[Optimizer]:
    """Add an optimiser class under its ``name``; refuses collisions."""
    if cls.name in OPTIMIZERS and OPTIMIZERS[cls.name] is not cls:
        raise ValueError(f"optimizer name {cls.name!r} is already registered by {OPTIMIZERS[cls.name]}")
    OPTIMIZERS[cls.name] = cls
    return cls


for _cls in (PSO, CMAES, CMAESRestart, DE, RandomSearch, Auto, TrustRegion):
    register(_cls)


def get_optimizer(name: str) -> type[Optimizer]:
    if name not in OPTIMIZERS:
        raise ValueError(f"unknown optimizer {name!r}; known: {sorted(OPTIMIZERS)}")
    return OPTIMIZERS[name]
