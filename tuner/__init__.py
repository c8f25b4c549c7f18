"""tuner: tune attitude filters and robot controllers by global optimisation.

Public API::

    import tuner
    params = tuner.load_best("runs/20261122T101500Z-demo-a1b2c3")   # every value of the tuned system
    result = tuner.run_config("configs/demo.yaml", seed=3)          # a RunResult
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

__version__ = "0.1.0"

__all__ = ["__version__", "load_best", "run_config"]


def load_best(run_dir: str | Path) -> dict[str, Any]:
    """Every value of a run's deployed filter or controller (searched, fixed and defaults; see
    :func:`tuner.deployment.load_deployment` for their sources and the scoring-only settings)."""
    from tuner.deployment import load_best as _load_best

    return _load_best(run_dir)


def run_config(path: str | Path, overrides: list[str] | None = None, seed: int | None = None,
               n_jobs: int | None = None, quiet: bool = True, run_dir: str | Path | None = None):
    """Load a YAML job and run it; returns a :class:`tuner.run.RunResult`."""
    from tuner.config import load_config
    from tuner.run import run

    return run(load_config(path, overrides, seed=seed, n_jobs=n_jobs), run_dir=run_dir, quiet=quiet)
