"""Fitness against each parameter: every successful evaluation (thinned to :data:`MAX_POINTS`), one panel per
searched parameter, in the coordinate the optimiser searched (log axes for log parameters), the search bounds
as lines, the best as a star; failed evaluations left out and counted."""

from __future__ import annotations

from typing import Any

import numpy as np

from tuner.figures import LEGEND_PT, TITLE_PT, grid_figure, log_y_if_wide, plain_log_labels
from tuner.plots.context import MAX_POINTS, RunContext

NAME = "slices"
FILE = "fitness_vs_params.png"


def data(ctx: RunContext) -> dict[str, Any] | None:
    """``params`` (name, unit, scale, low, high), ``points`` (fitness, eval, values per parameter), ``best``
    (the best point's searched values), ``best_fitness``, ``log``, ``n_ok``, ``n_failed``, ``n_shown``."""
    if not ctx.params or not len(ctx.ok):
        return None
    thin = ctx.thin
    return {"params": [{"name": p.name, "unit": p.unit, "scale": p.scale, "low": p.low, "high": p.high}
                       for p in ctx.params],
            "points": {"fitness": thin["fitness"].tolist(), "eval": thin["eval"].astype(int).tolist(),
                       "values": {p.name: thin[p.name].astype(float).tolist() for p in ctx.params}},
            "best": {p.name: float(ctx.best[p.name]) for p in ctx.params
                     if isinstance(ctx.best.get(p.name), (int, float))},
            "best_fitness": ctx.best_fitness, "log": ctx.log_fitness, "n_ok": len(ctx.ok), "n_failed": ctx.n_failed,
            "n_shown": len(thin)}


def title(d: dict[str, Any]) -> str:
    return "Fitness against each parameter"


def caption(d: dict[str, Any]) -> str:
    shown = "Every successful evaluation" if d["n_shown"] == d["n_ok"] else (
        f"{d['n_shown']} of the {d['n_ok']} successful evaluations (the best quarter of {MAX_POINTS} and an even "
        "spread)")
    return (f"{shown} (colour: evaluation number; lines: the search bounds; star: the best)"
            + (f"; {d['n_failed']} failed evaluations not shown." if d["n_failed"] else "."))


def figure(d: dict[str, Any]) -> Any:
    params, pts = d["params"], d["points"]
    fig, axes = grid_figure(len(params))
    fit = np.asarray(pts["fitness"], float)
    sc = None
    for i, (ax, p) in enumerate(zip(axes, params)):
        sc = ax.scatter(pts["values"][p["name"]], fit, c=pts["eval"], s=14, cmap="viridis", alpha=0.75, lw=0)
        if p["scale"] == "log":
            ax.set_xscale("log")
            plain_log_labels(ax.xaxis)
        for b in (p["low"], p["high"]):
            ax.axvline(b, color="tab:red", ls="--", lw=1)
        if p["name"] in d["best"]:
            ax.scatter([d["best"][p["name"]]], [d["best_fitness"]], marker="*", s=180, color="tab:red",
                       edgecolor="k", zorder=5, label="best")
        if d["log"]:
            log_y_if_wide(ax, fit)
        pad = 0.04
        if p["scale"] == "log":
            lo, hi = np.log10(p["low"]), np.log10(p["high"])
            ax.set_xlim(10 ** (lo - pad * (hi - lo)), 10 ** (hi + pad * (hi - lo)))
        else:
            ax.set_xlim(p["low"] - pad * (p["high"] - p["low"]), p["high"] + pad * (p["high"] - p["low"]))
        ax.set_xlabel(f"{p['name']} ({p['unit']})" if p["unit"] else p["name"])
        if i % 3 == 0:
            ax.set_ylabel("fitness")
        ax.grid(alpha=0.3)
    if d["best"]:
        axes[0].legend(loc="best", fontsize=LEGEND_PT)
    cax = fig.add_axes((0.92, 0.62 / fig.get_figheight(), 0.012, 1 - 1.07 / fig.get_figheight()))
    fig.colorbar(sc, cax=cax, label="evaluation")
    fig.suptitle(f"fitness against each parameter (dashed: search bounds; {d['n_shown']} evaluations"
                 + (f", {d['n_failed']} failed not shown)" if d["n_failed"] else ")"), fontsize=TITLE_PT)
    return fig


def slot(d: dict[str, Any]) -> dict[str, Any]:
    return {k: d[k] for k in ("params", "points", "best", "best_fitness", "log")}
