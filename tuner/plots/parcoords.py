"""Parallel coordinates of the best candidates: one line per candidate over each searched parameter's
position in its bounds (unit-cube coordinates, log10 for log parameters), in five bands of fitness rank.

Which candidates: the best tenth of the successful evaluations, at least 20 (or all there are) and at most
200 (:func:`n_best`). The plot shows where the good region of the space lies; a fixed count would mean
something else for each budget (200 of 100 evaluations is all of them, the bad ones included; 30 of 10,000 is
one basin), a fixed share keeps its meaning; the floor keeps a short run's plot from being three lines, the
cap keeps the page's SVG and the PNG legible.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from tuner.figures import LEGEND_PT, TITLE_PT, new_figure
from tuner.plots.context import RunContext

NAME = "parcoords"
FILE = "parallel_coordinates.png"
#: the five rank bands, worst to best (the same colours in ``tuner_report.js``)
BAND_COLORS = ("#d9d9d9", "#b4c7e7", "#7fa6d6", "#3f73b8", "#08306b")
SHARE, FLOOR, CAP = 0.1, 20, 200


def n_best(n_ok: int) -> int:
    """How many of ``n_ok`` successful evaluations the plot draws (module docstring)."""
    return min(CAP, max(min(n_ok, FLOOR), math.ceil(SHARE * n_ok)))


def bands(k: int, n: int = len(BAND_COLORS)) -> dict[str, list]:
    """Colour bands of ``k`` candidates sorted best first: ``band`` per candidate (n - 1 = the best fifth) and a
    label per band (``rank 1-6``; empty bands get ``""``)."""
    band = [n - 1 - (i * n) // k for i in range(k)]
    labels = []
    for b in range(n):
        ranks = [i + 1 for i in range(k) if band[i] == b]
        labels.append(f"rank {ranks[0]}-{ranks[-1]}" if len(ranks) > 1 else f"rank {ranks[0]}" if ranks else "")
    return {"band": band, "band_labels": labels}


def data(ctx: RunContext) -> dict[str, Any] | None:
    """``names``, ``ticks`` (name, bounds, log), ``u`` (k x d unit coordinates, best first), ``values``,
    ``fitness``, ``band`` and ``band_labels`` (:func:`bands`), ``n_ok``; None with fewer than two searched
    parameters (one axis is no parallel coordinates: the slice plot shows it) or no success."""
    params = ctx.params
    if len(params) < 2 or not len(ctx.ok):
        return None
    top = ctx.ok.sort_values("fitness", kind="stable").head(n_best(len(ctx.ok)))
    names = [p.name for p in params]
    return {"names": names,
            "ticks": [f"{p.name}\n[{p.low:.3g}, {p.high:.3g}]" + ("\nlog" if p.scale == "log" else "") for p in params],
            "u": np.round(ctx.unit(top), 5).tolist(), "values": top[names].astype(float).to_numpy().tolist(),
            "fitness": top["fitness"].tolist(), "n_ok": len(ctx.ok), **bands(len(top))}


def title(d: dict[str, Any]) -> str:
    return "Parallel coordinates of the best candidates"


def caption(d: dict[str, Any]) -> str:
    k = len(d["fitness"])
    return (f"The {k} best of {d['n_ok']} successful evaluations (the best tenth, at least 20, at most 200), one line "
            "each, over each parameter's position in its bounds (log10 for log parameters); darker = better, the "
            "best in red.")


def figure(d: dict[str, Any]) -> Any:
    fig = new_figure(4.2)
    ax = fig.subplots()
    xs = np.arange(len(d["names"]))
    u = np.asarray(d["u"], float)
    for b, color in enumerate(BAND_COLORS):  # worst band first, so the better ones are drawn on top
        rows = [i for i, bi in enumerate(d["band"]) if bi == b]
        for j, i in enumerate(rows[::-1]):
            ax.plot(xs, u[i], color=color, lw=2 if b == len(BAND_COLORS) - 1 else 1,
                    label=d["band_labels"][b] if j == 0 else None)
    ax.plot(xs, u[0], color="tab:red", lw=2.5, marker="o", label=f"best (fitness {d['fitness'][0]:.4g})")
    for x in xs:
        ax.axvline(x, color="k", lw=0.8)
    ax.axhline(0, color="tab:red", ls="--", lw=1)
    ax.axhline(1, color="tab:red", ls="--", lw=1)
    ax.set_xticks(xs, d["ticks"], fontsize=LEGEND_PT)
    if len(xs) > 8:
        ax.tick_params(axis="x", labelrotation=30)
    ax.set_ylim(-0.05, 1.05)
    ax.set_ylabel("position in bounds (0 = low, 1 = high)")
    ax.set_title(f"the {len(u)} best candidates in unit-cube coordinates (log parameters in log10)", fontsize=TITLE_PT)
    ax.legend(loc="upper left", bbox_to_anchor=(1.0, 1.0), fontsize=LEGEND_PT)
    ax.grid(alpha=0.3, axis="y")
    fig.tight_layout()
    return fig


def slot(d: dict[str, Any]) -> dict[str, Any]:
    return {k: d[k] for k in ("names", "u", "values", "fitness", "band", "band_labels")}
