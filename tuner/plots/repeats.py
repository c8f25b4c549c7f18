"""Convergence of every repeat of a repeated run (``repeats: N``): each seed's best fitness so far against its
evaluations, the deployed repeat drawn bold; the spread over seeds at a glance."""

from __future__ import annotations

from typing import Any

from tuner.figures import LEGEND_PT, new_figure
from tuner.plots.context import RunContext, log_scale
from tuner.plots.sweep_convergence import best_so_far, finish_best_so_far
from tuner.records import RunError
from tuner.rundir import RunDir

NAME = "repeats"
FILE = "repeats_convergence.png"


def data(ctx: RunContext) -> dict[str, Any] | None:
    """``runs``: ``{seed, chosen, x, y}`` per repeat with a successful evaluation; ``log``; None for a single run."""
    try:
        rep = RunDir(ctx.run_dir).repeats()
    except (OSError, RunError):
        return None
    if rep is None:
        return None
    runs = []
    for e in rep.entries:
        c = best_so_far(ctx.run_dir / e.run)
        if c is not None:
            runs.append({"seed": e.seed, "chosen": rep.chosen == e.index, **c})
    if len(runs) < 2:
        return None
    return {"runs": runs, "log": log_scale([v for r in runs for v in (r["y"][0], r["y"][-1])]),
            "rule": rep.rule}


def title(d: dict[str, Any]) -> str:
    return "Convergence of every repeat"


def caption(d: dict[str, Any]) -> str:
    rule = f" The bold curve is the deployed repeat: {d['rule']}." if d.get("rule") else ""
    return f"Best fitness so far of each of the {len(d['runs'])} seeds against its evaluations.{rule}"


def figure(d: dict[str, Any]) -> Any:
    fig = new_figure(4.0)
    ax = fig.subplots()
    for r in d["runs"]:
        ax.plot(r["x"], r["y"], lw=2.4 if r["chosen"] else 1.0, alpha=1.0 if r["chosen"] else 0.7,
                label=f"seed {r['seed']}" + (" (deployed)" if r["chosen"] else ""))
    ax.legend(fontsize=LEGEND_PT, ncol=2 if len(d["runs"]) > 6 else 1)
    return finish_best_so_far(fig, ax, d)


def slot(d: dict[str, Any]) -> None:
    return None
