"""The contract between the engine and any objective.

An objective is a picklable callable ``objective(params: dict) -> Evaluation`` (a bare float, or a
``(float, dict)`` pair, is accepted too and normalised by :func:`as_evaluation`). Lower fitness is
better. The engine never looks inside: it decodes candidates, calls the objective (in this process
or in workers), and records what comes back.

Objectives that are expensive to set up (data loading, compilation) do it lazily on the first call,
so pickling them to workers stays cheap and each worker builds its state once.

Optional hooks the engine uses when present:

- ``default_space() -> tuner.space.Space``: parameters to search when the config gives none;
- ``finalize(run_dir, best_params) -> dict``: after a run, extra scores (held-out data) and report
  figures; returns metrics that go into ``best.yaml`` and the report.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Literal, Protocol, runtime_checkable

__all__ = ["Evaluation", "Objective", "as_evaluation", "PENALTY"]

#: fitness given to failed evaluations (exception, NaN, inf); finite so every optimiser copes.
PENALTY = 1.0e12


@dataclass(frozen=True)
class Evaluation:
    """Result of one evaluation.

    Attributes
    ----------
    fitness : float
        Value to minimise; finite when ``status == "ok"``.
    metrics : dict[str, float]
        Named breakdown (per recording, per axis...), written to ``history.csv`` and reports.
    status : {"ok", "failed"}
        ``failed`` when the candidate could not be scored (diverged filter, fallen robot, exception).
    error : str
        Why it failed; empty when ok.
    """

    fitness: float
    metrics: dict[str, float] = field(default_factory=dict)
    status: Literal["ok", "failed"] = "ok"
    error: str = ""

    @classmethod
    def failed(cls, error: str, metrics: dict[str, float] | None = None) -> Evaluation:
        return cls(PENALTY, dict(metrics or {}), "failed", error)


@runtime_checkable
class Objective(Protocol):
    def __call__(self, params: dict[str, Any]) -> Evaluation | float | tuple[float, dict]: ...


def as_evaluation(value: Any) -> Evaluation:
    """Normalise what an objective returned; non-finite fitness becomes a failed evaluation."""
    if isinstance(value, Evaluation):
        ev = value
    elif isinstance(value, tuple) and len(value) == 2:
        ev = Evaluation(float(value[0]), dict(value[1]))
    else:
        try:
            ev = Evaluation(float(value))
        except (TypeError, ValueError):
            return Evaluation.failed(f"objective returned {type(value).__name__}, expected a number")
    if ev.status == "ok" and not math.isfinite(ev.fitness):
        return Evaluation(PENALTY, ev.metrics, "failed", f"non-finite fitness {ev.fitness}")
    if ev.status == "failed" and not math.isfinite(ev.fitness):
        return Evaluation(PENALTY, ev.metrics, "failed", ev.error)
    return ev
