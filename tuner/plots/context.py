"""What a report's plots are computed from: the run (or sweep) read once, and the pieces several plots share.

:class:`RunContext` holds a run's history and space and computes, each once and only if a plot asks, the
successful evaluations, the free parameters the history holds, whether fitness is drawn on a log axis, the
thinned point cloud of the scatter plots and the parameter importance (which the importance plot shows and
the contour plot uses to pick its two parameters). :class:`SweepContext` holds a sweep's finished jobs.
"""

from __future__ import annotations

import io
import math
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from tuner.importance import Importance, quadratic_anova
from tuner.records import RunError
from tuner.safe_io import read_text, regular

__all__ = ["RunContext", "SweepContext", "load_history", "MAX_POINTS"]

#: at most this many evaluations go into the scatter plots (the best ones and an even spread of the rest)
MAX_POINTS = 4000


def load_history(run_dir: Path) -> pd.DataFrame:
    """``history.csv`` as a frame; a missing or unparsable file raises :class:`tuner.records.RunError`."""
    p = Path(run_dir) / "history.csv"
    if not regular(p):
        raise RunError(f"{p}: missing (nothing evaluated yet?)")
    try:  # through tuner.safe_io: a link or a FIFO named history.csv is refused, never followed or waited on
        df = pd.read_csv(io.StringIO(read_text(p)), keep_default_na=False, na_values=[""])
    except (pd.errors.ParserError, pd.errors.EmptyDataError, UnicodeDecodeError) as exc:
        raise RunError(f"{p}: unreadable: {str(exc).strip()}") from None
    missing = [c for c in ("eval", "stage", "generation", "fitness", "status") if c not in df.columns]
    if missing:
        raise RunError(f"{p}: missing columns {missing}")
    return df


def log_scale(f: Any) -> bool:
    """Fitness values drawn on a log axis: all positive and spanning more than a factor 20."""
    f = np.asarray(f, float)
    f = f[np.isfinite(f)]
    return bool(len(f) and f.min() > 0 and f.max() / f.min() > 20)


@dataclass
class RunContext:
    """One run's plot inputs.

    Attributes
    ----------
    run_dir : Path
    hist : DataFrame
        ``history.csv`` (:func:`load_history`).
    space : tuner.space.Space or None
        The run's search space (None when it no longer builds: only the convergence is drawn then).
    best : dict
        The best parameters (``best.yaml``'s ``params``).
    """

    run_dir: Path
    hist: pd.DataFrame
    space: Any = None
    best: dict[str, Any] = field(default_factory=dict)

    @cached_property
    def ok(self) -> pd.DataFrame:
        """The successful evaluations with a finite fitness (as floats)."""
        h = self.hist
        ok = h[(h["status"] == "ok") & np.isfinite(pd.to_numeric(h["fitness"], errors="coerce"))].copy()
        ok["fitness"] = ok["fitness"].astype(float)
        return ok

    @cached_property
    def n_failed(self) -> int:
        return int((self.hist["status"] != "ok").sum())

    @cached_property
    def params(self) -> list[Any]:
        """The space's free parameters that ``history.csv`` has columns for."""
        return [p for p in (self.space.free if self.space is not None else []) if p.name in self.hist.columns]

    @cached_property
    def log_fitness(self) -> bool:
        return log_scale(self.ok["fitness"])

    @cached_property
    def thin(self) -> pd.DataFrame:
        """At most :data:`MAX_POINTS` successful rows: the best quarter of them, then an even spread of the others."""
        ok = self.ok
        if len(ok) <= MAX_POINTS:
            return ok
        s = ok.sort_values("fitness", kind="stable")
        top = s.head(MAX_POINTS // 4)
        rest = s.iloc[MAX_POINTS // 4:]
        idx = np.linspace(0, len(rest) - 1, MAX_POINTS - len(top)).round().astype(int)
        return pd.concat([top, rest.iloc[np.unique(idx)]]).sort_values("eval")

    def unit(self, rows: pd.DataFrame) -> np.ndarray:
        """``(len(rows), len(params))``: the rows' parameters in unit-cube coordinates (log10 for log ones)."""
        return np.array([[p.to_unit(float(v)) for p, v in zip(self.params, row)]
                         for row in rows[[p.name for p in self.params]].to_numpy()]).reshape(len(rows), -1)

    @cached_property
    def importance(self) -> Importance | None:
        """Quadratic functional ANOVA over the successful evaluations (:mod:`tuner.importance`), or None."""
        if not self.params or not len(self.ok):
            return None
        return quadratic_anova(self.unit(self.ok), self.ok["fitness"].to_numpy(), [p.name for p in self.params])

    @cached_property
    def best_fitness(self) -> float:
        return float(self.ok["fitness"].min()) if len(self.ok) else math.nan


@dataclass
class SweepContext:
    """One sweep's plot inputs: its directory, its jobs (:func:`tuner.sweep.collect`: one row per job with
    ``job``, ``method``, ``status``, ``best_fitness``, scores, ``param.*``, ``grid.*``) and the score it ranks by
    (``(column, words)``, :func:`tuner.sweep.ranked_by`)."""

    sweep_dir: Path
    jobs: pd.DataFrame
    ranked_by: tuple[str, str] = ("best_fitness", "train score")

    @cached_property
    def done(self) -> pd.DataFrame:
        """The finished jobs (with a best fitness)."""
        df = self.jobs
        if not len(df) or "best_fitness" not in df:
            return df.iloc[0:0]
        return df[df["status"] == "finished"]

    @cached_property
    def methods(self) -> list[str]:
        return sorted(self.done["method"].unique()) if len(self.done) else []
