"""Best parameters of every job of a sweep within their bounds: each job's best point in unit coordinates of
its own search space (log10 for log parameters), one column per parameter, coloured by method."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from tuner.bounds import run_space
from tuner.figures import TITLE_PT, method_color, new_figure
from tuner.plots.context import SweepContext

NAME = "best_parameters"
FILE = "best_parameters.png"


def data(ctx: SweepContext) -> dict[str, Any] | None:
    """``names``, ``ticks`` (name, bounds, log), ``methods`` and ``points``: ``[name, method, unit position]``;
    None when no job's space rebuilds."""
    names: list[str] = []
    ticks: dict[str, str] = {}
    points = []
    for _, r in ctx.done.iterrows():
        space = run_space(Path(ctx.sweep_dir) / "jobs" / r["job"])
        if space is None:
            continue
        for p in space.free:
            col = f"param.{p.name}"
            if col not in r or pd.isna(r[col]):
                continue
            if p.name not in names:
                names.append(p.name)
                ticks[p.name] = f"{p.name}\n[{p.low:.3g}, {p.high:.3g}]" + ("\nlog" if p.scale == "log" else "")
            points.append([p.name, r["method"], p.to_unit(float(r[col]))])
    if not names:
        return None
    return {"names": names, "ticks": [ticks[n] for n in names], "methods": ctx.methods, "points": points}


def title(d: dict[str, Any]) -> str:
    return "Best parameters of every job within their bounds"


def caption(d: dict[str, Any]) -> str:
    return ""


def figure(d: dict[str, Any]) -> Any:
    fig = new_figure(4.4)
    ax = fig.subplots()
    names, methods = d["names"], d["methods"]
    width = 0.6
    for i, m in enumerate(methods):
        off = (i - (len(methods) - 1) / 2) * width / max(len(methods), 1)
        pts = [(names.index(n), u) for n, mm, u in d["points"] if mm == m]
        if pts:
            x, u = np.array(pts).T
            ax.scatter(x + off, u, color=method_color(i), s=40, label=m, edgecolor="k", lw=0.4, zorder=3)
    ax.axhline(0, color="tab:red", ls="--", lw=1)
    ax.axhline(1, color="tab:red", ls="--", lw=1)
    ax.set_xticks(range(len(names)), d["ticks"], fontsize=8)
    if len(names) > 8:
        ax.tick_params(axis="x", labelrotation=30)
    ax.set_ylim(-0.05, 1.05)
    ax.set_ylabel("position in bounds (0 = low, 1 = high)")
    ax.set_title("best parameters of every job (dashed: search bounds; log parameters in log10)", fontsize=TITLE_PT)
    ax.grid(alpha=0.3, axis="y")
    ax.legend(fontsize=8, ncol=min(4, len(methods)), loc="upper center", bbox_to_anchor=(0.5, -0.28))
    fig.tight_layout()
    return fig


def slot(d: dict[str, Any]) -> None:
    return None
