"""Responses of each method's best job (lowest fitness), through its objective's ``traces(params)`` hook, on
shared axes: one panel per trace the objective names, one line per method (e.g. a closed-loop sweep: speed,
yaw rate, IB angle and current against their references)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from tuner.figures import method_color, new_figure
from tuner.objective import hook
from tuner.plots.context import SweepContext
from tuner.records import RunError
from tuner.registry import build_objective
from tuner.rundir import RunDir

NAME = "responses"
FILE = "responses.png"


def data(ctx: SweepContext) -> dict[str, Any] | None:
    """``curves``: ``{method: {"fitness", "traces": {panel: {"t", "y", "ref"}}}}``; None unless every method's
    best job rebuilds its objective and has the hook (a report never imports code a run directory names: a
    ``kind: python`` objective is never rebuilt)."""
    done, curves = ctx.done, {}
    for m in ctx.methods:
        job = done[done["method"] == m].sort_values("best_fitness")["job"].iloc[0]
        rd = RunDir(Path(ctx.sweep_dir) / "jobs" / job)
        try:
            cfg, best = rd.config(), rd.best()
            if cfg["objective"].get("kind") == "python":
                return None
            obj = build_objective(dict(cfg["objective"]), Path(cfg.get("base_dir", rd.path)))
        except (RunError, ValueError, OSError, ImportError, KeyError, AttributeError):
            return None
        fn = hook(obj, "traces")
        if fn is None:
            return None
        curves[m] = {"fitness": best.fitness, "traces": {name: {k: None if v is None else np.asarray(v).tolist()
                                                                for k, v in c.items()}
                                                         for name, c in dict(fn(dict(best.params))).items()}}
    return {"curves": curves} if curves else None


def title(d: dict[str, Any]) -> str:
    return "Responses of each method's best job"


def caption(d: dict[str, Any]) -> str:
    return ""


def figure(d: dict[str, Any]) -> Any:
    curves = d["curves"]
    labels = list(next(iter(curves.values()))["traces"])
    fig = new_figure(2.1 * len(labels) + 0.6)
    axes = fig.subplots(len(labels), 1, sharex=True, squeeze=False)[:, 0]
    ref_drawn = set()
    for i, (m, cv) in enumerate(curves.items()):
        for ax, name in zip(axes, labels):
            c = cv["traces"].get(name)
            if c is None:
                continue
            t, y = np.asarray(c["t"], float), np.asarray(c["y"], float)
            n = min(len(t), len(y))
            ax.plot(t[:n], y[:n], color=method_color(i), lw=1.1, label=f"{m} (best {cv['fitness']:.4g})")
            if c.get("ref") is not None and name not in ref_drawn:
                ref = np.asarray(c["ref"], float)
                k = min(len(t), len(ref))
                ax.plot(t[:k], ref[:k], "k:", lw=1.2, label="reference")
                ref_drawn.add(name)
            ax.set_ylabel(name)
            ax.grid(alpha=0.3)
    axes[0].legend(fontsize=8, ncol=2, loc="lower left", bbox_to_anchor=(0.0, 1.02), borderaxespad=0)
    axes[-1].set_xlabel("time (s)")
    fig.suptitle("response of the best job of each method", y=0.995)
    fig.tight_layout()
    return fig


def slot(d: dict[str, Any]) -> None:
    return None
