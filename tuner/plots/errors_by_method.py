"""Attitude errors per axis and method (filter sweeps): the median over seeds as bars, each job as a point, on
the test recordings where the jobs have them, else the training ones."""

from __future__ import annotations

from typing import Any

import numpy as np

from tuner.figures import LEGEND_PT, TITLE_PT, method_color, new_figure
from tuner.plots.context import SweepContext

NAME = "errors_by_method"
FILE = "errors_by_method.png"
AXES = ("roll", "pitch", "yaw", "total")


def data(ctx: SweepContext) -> dict[str, Any] | None:
    """``split``, ``axes`` (the columns' axis names), ``methods`` and ``values[method][axis]``: the jobs' RMSE in
    degrees; None when the jobs report no ``<split>.<axis>_rmse_deg`` (not a filter sweep)."""
    done = ctx.done
    split = "test" if any(c.startswith("test.") for c in done.columns) else "train"
    cols = [c for c in (f"{split}.{a}_rmse_deg" for a in AXES) if c in done.columns and done[c].notna().any()]
    if not len(done) or not cols:
        return None
    return {"split": split, "axes": [c.split(".", 1)[1].replace("_rmse_deg", "") for c in cols],
            "methods": ctx.methods,
            "values": [[done[done["method"] == m][c].astype(float).dropna().tolist() for c in cols]
                       for m in ctx.methods]}


def title(d: dict[str, Any]) -> str:
    return f"{d['split'].capitalize()} errors per axis and method"


def caption(d: dict[str, Any]) -> str:
    return ""


def figure(d: dict[str, Any]) -> Any:
    fig = new_figure(3.8)
    ax = fig.subplots()
    methods, n_axes = d["methods"], len(d["axes"])
    w = 0.8 / len(methods)
    for i, (m, per_axis) in enumerate(zip(methods, d["values"])):
        x = np.arange(n_axes) + (i - (len(methods) - 1) / 2) * w
        ax.bar(x, [float(np.median(v)) if v else np.nan for v in per_axis], width=w, color=method_color(i), label=m,
               alpha=0.85)
        for j, v in enumerate(per_axis):
            ax.scatter(np.full(len(v), x[j]), v, s=10, color="k", zorder=3)
    ax.set_xticks(range(n_axes), d["axes"])
    ax.set_ylabel(f"{d['split']} RMSE (deg), median and seeds")
    ax.set_title(f"attitude errors per method on the {d['split']} recordings", fontsize=TITLE_PT)
    ax.legend(fontsize=LEGEND_PT)
    ax.grid(alpha=0.3, axis="y")
    fig.tight_layout()
    return fig


def slot(d: dict[str, Any]) -> None:
    return None
