"""tuner: tune attitude filters and robot controllers by global optimisation.

Public API (:mod:`tuner.api`; README, section "Python API")::

    import tuner
    result = tuner.tune("configs/ekf_bench6dof.yaml", seed=3)   # or a dict, or a RunConfig -> Result
    result.fitness, result.best, result.history                  # best fitness, complete configuration, DataFrame
    flt = result.build()                                         # the tuned filter, ready for .run(...)
    same = tuner.load(result.run_dir)                            # the Result of a run on disk
    params = tuner.load_best(result.run_dir)                     # dict of the deployed values
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from tuner._version import __version__

__all__ = ["__version__", "tune", "load", "Result", "GenerationSummary", "ConfigError", "RunError", "load_best",
           "run_config"]

#: names served lazily from tuner.api, so that `import tuner` (and `tuner --version`) stays light
_API = {"tune", "load", "Result", "GenerationSummary", "ConfigError", "RunError"}


def __getattr__(name: str) -> Any:
    if name in _API:
        from tuner import api

        return getattr(api, name)
    raise AttributeError(f"module 'tuner' has no attribute {name!r}")


def load_best(run_dir: str | Path) -> dict[str, Any]:
    """Every value of a run's deployed filter or controller (searched, fixed and defaults; see
    :func:`tuner.deployment.load_deployment` for their sources and the scoring-only settings)."""
    from tuner.deployment import load_best as _load_best

    return _load_best(run_dir)


def run_config(path: str | Path, overrides: list[str] | None = None, seed: int | None = None,
               n_jobs: int | None = None, quiet: bool = True, run_dir: str | Path | None = None):
    """Load a YAML job and run it; returns a :class:`tuner.run.RunResult` (:func:`tune` returns the richer
    :class:`tuner.api.Result`)."""
    from tuner.config import load_config
    from tuner.run import run

    return run(load_config(path, overrides, seed=seed, n_jobs=n_jobs), run_dir=run_dir, quiet=quiet)
