"""Parameter importance: each searched parameter's share of the explained variance of the fitness ranks
(quadratic functional ANOVA, :mod:`tuner.importance`)."""

from __future__ import annotations

from typing import Any

from tuner.figures import new_figure
from tuner.importance import importance_caption
from tuner.plots.context import RunContext

NAME = "importance"
FILE = "importance.png"


def data(ctx: RunContext) -> dict[str, Any] | None:
    """``names`` from the most to the least important, their ``share`` (sums to 1), the ``caption``; None with
    fewer than two searched parameters or too few evaluations for the fit."""
    imp = ctx.importance
    if imp is None or len(ctx.params) < 2:
        return None
    order = imp.order()
    return {"names": order, "share": [float(imp.share[imp.names.index(n)]) for n in order],
            "caption": importance_caption(imp)}


def title(d: dict[str, Any]) -> str:
    return "Parameter importance"


def caption(d: dict[str, Any]) -> str:
    return d["caption"]


def figure(d: dict[str, Any]) -> Any:
    n = len(d["names"])
    fig = new_figure(1.0 + 0.3 * n)
    ax = fig.subplots()
    ax.barh(range(n)[::-1], d["share"], color="tab:blue")
    ax.set_yticks(range(n)[::-1], d["names"])
    ax.set_xlim(0, 1)
    ax.xaxis.set_major_formatter("{x:.0%}")
    ax.set_xlabel("share of explained variance")
    ax.grid(alpha=0.3, axis="x")
    fig.tight_layout()
    return fig


def slot(d: dict[str, Any]) -> dict[str, Any]:
    return {"names": d["names"], "share": d["share"]}
