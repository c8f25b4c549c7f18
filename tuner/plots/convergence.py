"""Convergence: the best fitness so far and each generation's median against evaluations."""

from __future__ import annotations

from typing import Any

import pandas as pd

from tuner.figures import LEGEND_PT, TITLE_PT, log_y_if_wide, new_figure
from tuner.plots.context import RunContext, log_scale

NAME = "convergence"
FILE = "convergence.png"


def convergence_table(hist: pd.DataFrame) -> pd.DataFrame:
    """Per generation: best of the generation, median, best so far and evaluations so far."""
    ok = hist[hist["status"] == "ok"]
    g = ok.groupby(["stage", "generation"])["fitness"]
    df = pd.DataFrame({"gen_best": g.min(), "gen_median": g.median()}).reset_index()
    evals = hist.groupby(["stage", "generation"])["eval"].max().reset_index()
    df = df.merge(evals, on=["stage", "generation"], how="right").sort_values("eval")
    df["best"] = df["gen_best"].cummin()
    df["n_evals"] = df["eval"] + 1
    return df


def data(ctx: RunContext) -> dict[str, Any] | None:
    """``n_evals``, ``best`` (so far), ``gen_median`` per generation (NaN before the first success: JSON null);
    ``stage_starts``: the evaluation count at which each refinement stage after the first begins; ``log``:
    fitness on a log axis; ``run``: its name."""
    if not len(ctx.hist):
        return None
    conv = convergence_table(ctx.hist)
    starts = [int(conv[conv["stage"] == s]["n_evals"].min()) for s in sorted(conv["stage"].unique())[1:]]
    return {"n_evals": conv["n_evals"].astype(int).tolist(), "best": conv["best"].astype(float).tolist(),
            "gen_median": conv["gen_median"].astype(float).tolist(), "stage_starts": starts,
            "log": log_scale(conv[["best", "gen_median"]].to_numpy().ravel()), "run": ctx.run_dir.name}


def title(d: dict[str, Any]) -> str:
    return "Convergence"


def caption(d: dict[str, Any]) -> str:
    return "Best fitness so far and each generation's median against evaluations" + (
        " (dotted: where a refinement stage starts)." if d["stage_starts"] else ".")


def figure(d: dict[str, Any]) -> Any:
    fig = new_figure(3.8)
    ax = fig.subplots()
    ax.plot(d["n_evals"], d["best"], label="best so far", lw=2)
    ax.plot(d["n_evals"], d["gen_median"], label="generation median", lw=1, alpha=0.7)
    if d["log"]:
        log_y_if_wide(ax, d["best"] + d["gen_median"])
    for x in d["stage_starts"]:
        ax.axvline(x, color="grey", ls=":", lw=1)
    ax.set_xlabel("evaluations")
    ax.set_ylabel("fitness")
    ax.set_title(f"convergence of {d['run']}", fontsize=TITLE_PT)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=LEGEND_PT)
    fig.tight_layout()
    return fig


def slot(d: dict[str, Any]) -> dict[str, Any]:
    return d
