"""Convergence of every job of a sweep: each job's best fitness so far against its evaluations, coloured by
method."""

from __future__ import annotations

import io
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from tuner.figures import LEGEND_PT, log_y_if_wide, method_color, new_figure
from tuner.plots.context import SweepContext, log_scale
from tuner.safe_io import read_text

NAME = "convergence"
FILE = "convergence_all.png"
#: at most this many points per job's curve
POINTS = 200


def best_so_far(run_dir: Path, points: int = POINTS) -> dict[str, list[float]] | None:
    """A run's best fitness so far against evaluations (``x``, ``y``; at most ``points``), or None."""
    try:  # through tuner.safe_io: a link or a FIFO named history.csv is no curve, never followed or waited on
        h = pd.read_csv(io.StringIO(read_text(Path(run_dir) / "history.csv")), usecols=["eval", "fitness", "status"])
    except (OSError, ValueError, pd.errors.ParserError, pd.errors.EmptyDataError):
        return None
    f = pd.to_numeric(h["fitness"], errors="coerce").where(h["status"] == "ok")
    best = f.cummin().to_numpy()
    x = (h["eval"].to_numpy() + 1).astype(float)
    keep = np.isfinite(best)
    if not keep.any():
        return None
    x, best = x[keep], best[keep]
    if len(x) > points:
        idx = np.unique(np.linspace(0, len(x) - 1, points).round().astype(int))
        x, best = x[idx], best[idx]
    return {"x": x.tolist(), "y": best.tolist()}


def data(ctx: SweepContext) -> dict[str, Any] | None:
    """``runs``: ``{name, method, x, y}`` per job with a successful evaluation (:func:`best_so_far`); ``log``."""
    runs = []
    for _, r in ctx.jobs.iterrows():
        c = best_so_far(Path(ctx.sweep_dir) / "jobs" / r["job"])
        if c is not None:
            runs.append({"name": r["job"], "method": r["method"], **c})
    if not runs:
        return None
    return {"runs": runs, "log": log_scale([v for r in runs for v in (r["y"][0], r["y"][-1])])}


def title(d: dict[str, Any]) -> str:
    return "Convergence of every job"


def caption(d: dict[str, Any]) -> str:
    return "Best fitness so far of each job against its evaluations (colour: method)."


def finish_best_so_far(fig: Any, ax: Any, d: dict[str, Any]) -> Any:
    """The axes of a best-so-far plot of ``d["runs"]`` (``x`` evaluations, ``y`` best fitness; log y when
    ``d["log"]`` and the values span decades), laid out; returns ``fig``."""
    if d["log"]:
        log_y_if_wide(ax, [v for r in d["runs"] for v in r["y"]])
    ax.set_xlabel("evaluations")
    ax.set_ylabel("best fitness so far")
    ax.grid(alpha=0.3)
    fig.tight_layout()
    return fig


def figure(d: dict[str, Any]) -> Any:
    fig = new_figure(4.0)
    ax = fig.subplots()
    methods = sorted({r["method"] for r in d["runs"]})
    seen = set()
    for r in d["runs"]:
        ax.plot(r["x"], r["y"], color=method_color(methods.index(r["method"])), alpha=0.8, lw=1.2,
                label=None if r["method"] in seen else r["method"])
        seen.add(r["method"])
    ax.legend(fontsize=LEGEND_PT)
    return finish_best_so_far(fig, ax, d)


def slot(d: dict[str, Any]) -> dict[str, Any]:
    return {"runs": [{"name": r["name"], "x": r["x"], "y": r["y"]} for r in d["runs"]], "log": d["log"]}
