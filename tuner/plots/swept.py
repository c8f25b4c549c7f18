"""The score against a swept value: when a sweep's grid varies a number (``grid: {objective.requirements.max_ms:
[1.2, 1.4, ...]}``), each finished job's score (the one the sweep ranks by) against that value, one series per
method and the other grid values, with the median over seeds joined by a line: a trade-off curve (the IAE a
PID reaches against the robustness limit it must meet, a filter's error against a noise level)."""

from __future__ import annotations

from typing import Any

import numpy as np
import pandas as pd

from tuner.figures import LEGEND_PT, log_y_if_wide, method_color, new_figure
from tuner.plots.context import SweepContext

NAME = "swept"
FILE = "score_vs_swept.png"
#: the fewest distinct values of a grid key that make a curve
MIN_VALUES = 3


def data(ctx: SweepContext) -> dict[str, Any] | None:
    """``key`` (the first numeric grid key with at least :data:`MIN_VALUES` values), ``score`` (its column and
    words), ``series`` (one per variant and values of the other grid keys): ``[{name, x, y (every job), mx,
    my (median per x)}]``; None without such a key."""
    done = ctx.done
    keys = [c for c in done.columns if c.startswith("grid.") and done[c].notna().all()
            and done[c].nunique() >= MIN_VALUES] if len(done) else []
    if not keys:
        return None
    key = keys[0]
    col, words = ctx.ranked_by
    others = [c for c in done.columns if c.startswith("grid.") and c != key]
    series = []
    variant = done["variant"].astype(str) if "variant" in done else pd.Series("", index=done.index)
    for label, grp in done.groupby([variant, *[done[c].astype(str) for c in others]], sort=True):
        label = label if isinstance(label, tuple) else (label,)
        name = ", ".join([p for p in (label[0], *(f"{c[5:]}={v}" for c, v in zip(others, label[1:]))) if p]) \
            or "jobs"
        x = grp[key].astype(float).to_numpy()
        y = pd.to_numeric(grp[col], errors="coerce").to_numpy(dtype=float)
        keep = np.isfinite(x) & np.isfinite(y)
        x, y = x[keep], y[keep]
        mx = np.unique(x)
        series.append({"name": name, "x": x.tolist(), "y": y.tolist(), "mx": mx.tolist(),
                       "my": [float(np.median(y[x == v])) for v in mx]})
    if not any(s["x"] for s in series):
        return None
    return {"key": key[5:], "score": col, "words": words, "series": series}


def title(d: dict[str, Any]) -> str:
    return f"{d['score'].replace('_', ' ').capitalize()} against {d['key']}"


def caption(d: dict[str, Any]) -> str:
    return (f"each finished job's {d['words']} ({d['score']}) against the value of {d['key']} it ran with; the line "
            "joins the medians over seeds")


def figure(d: dict[str, Any]) -> Any:
    fig = new_figure(3.8)
    ax = fig.subplots()
    ys = []
    for i, s in enumerate(d["series"]):
        ax.scatter(s["x"], s["y"], s=18, color=method_color(i), edgecolor="k", lw=0.4, zorder=3)
        ax.plot(s["mx"], s["my"], "-", color=method_color(i), lw=1.5, label=s["name"])
        ys += s["y"]
    log_y_if_wide(ax, np.asarray(ys, dtype=float))
    ax.set_xlabel(d["key"])
    ax.set_ylabel(d["score"].replace("_", " "))
    ax.grid(alpha=0.3)
    if len(d["series"]) > 1:
        ax.legend(fontsize=LEGEND_PT, loc="best")
    fig.tight_layout()
    return fig


def slot(d: dict[str, Any]) -> dict[str, Any]:
    """The same data for ``tuner_report.js`` (``PLOTS.swept``)."""
    return d
