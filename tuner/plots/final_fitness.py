"""Final fitness per method over a sweep's seeds: a box per method and each job as a point (the test fitness
where the jobs have one, else the best fitness)."""

from __future__ import annotations

from typing import Any

import numpy as np

from tuner.figures import log_y_if_wide, method_color, new_figure
from tuner.plots.context import SweepContext

NAME = "final_fitness"
FILE = "final_fitness_box.png"


def data(ctx: SweepContext) -> dict[str, Any] | None:
    """``column`` (``test_fitness`` or ``best_fitness``), ``methods`` and ``values`` (one list per method)."""
    done = ctx.done
    if not len(done):
        return None
    col = "test_fitness" if "test_fitness" in done and done["test_fitness"].notna().any() else "best_fitness"
    return {"column": col, "methods": ctx.methods,
            "values": [done[done["method"] == m][col].astype(float).dropna().tolist() for m in ctx.methods]}


def title(d: dict[str, Any]) -> str:
    return f"Final {d['column'].replace('_', ' ')} per method over seeds"


def caption(d: dict[str, Any]) -> str:
    return ""


def figure(d: dict[str, Any]) -> Any:
    fig = new_figure(3.8)
    ax = fig.subplots()
    methods, values = d["methods"], [np.asarray(v, float) for v in d["values"]]
    ax.boxplot(values, tick_labels=methods, showmeans=True)
    rng = np.random.default_rng(0)  # fixed jitter: the figure is a function of the results
    for i, v in enumerate(values):
        ax.scatter(i + 1 + rng.uniform(-0.08, 0.08, len(v)), v, s=16, color=method_color(i), edgecolor="k", lw=0.4,
                   zorder=3)
    log_y_if_wide(ax, np.concatenate(values) if values else np.array([]))
    ax.set_ylabel(d["column"].replace("_", " "))
    ax.tick_params(axis="x", labelrotation=15 if len(methods) > 4 else 0, labelsize=9)
    ax.grid(alpha=0.3, axis="y")
    fig.tight_layout()
    return fig


def slot(d: dict[str, Any]) -> None:
    return None
