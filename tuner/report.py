"""Run reports: ``report.md`` with the result table and a convergence figure.

Objectives can add their own figures (error traces, fuzzy surfaces) through their ``finalize`` hook;
those land in ``figures/`` and are listed in the report.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import yaml

__all__ = ["write_run_report", "plot_convergence", "load_history", "run_summary"]


def load_history(run_dir: Path) -> pd.DataFrame:
    return pd.read_csv(Path(run_dir) / "history.csv", keep_default_na=False, na_values=[""])


def _convergence(hist: pd.DataFrame) -> pd.DataFrame:
    ok = hist[hist["status"] == "ok"]
    g = ok.groupby(["stage", "generation"])["fitness"]
    df = pd.DataFrame({"gen_best": g.min(), "gen_median": g.median()}).reset_index()
    evals = hist.groupby(["stage", "generation"])["eval"].max().reset_index()
    df = df.merge(evals, on=["stage", "generation"], how="right").sort_values("eval")
    df["best"] = df["gen_best"].cummin()
    df["n_evals"] = df["eval"] + 1
    return df


def plot_convergence(run_dir: Path, path: Path | None = None) -> Path:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    run_dir = Path(run_dir)
    conv = _convergence(load_history(run_dir))
    path = path or run_dir / "figures" / "convergence.png"
    path.parent.mkdir(parents=True, exist_ok=True)
    fig, ax = plt.subplots(figsize=(6.4, 3.8), dpi=110)
    ax.plot(conv["n_evals"], conv["best"], label="best so far", lw=2)
    ax.plot(conv["n_evals"], conv["gen_median"], label="generation median", lw=1, alpha=0.7)
    pos = conv[["best", "gen_median"]].to_numpy()
    if np.nanmin(pos) > 0 and np.nanmax(pos) / max(np.nanmin(pos), 1e-300) > 20:
        ax.set_yscale("log")
    for s in sorted(conv["stage"].unique())[1:]:
        ax.axvline(conv[conv["stage"] == s]["n_evals"].min(), color="grey", ls=":", lw=1)
    ax.set_xlabel("evaluations")
    ax.set_ylabel("fitness")
    ax.set_title(run_dir.name, fontsize=9)
    ax.grid(alpha=0.3)
    ax.legend()
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)
    return path


def run_summary(run_dir: Path) -> dict[str, Any]:
    """Status, best fitness, parameters and counts of a run directory."""
    run_dir = Path(run_dir)
    meta = json.loads((run_dir / "meta.json").read_text())
    best = {}
    if (run_dir / "best.yaml").exists():
        best = yaml.safe_load((run_dir / "best.yaml").read_text()) or {}
    return {"run": run_dir.name, "status": meta.get("status"), "optimizer": meta.get("optimizer"),
            "seed": meta.get("seed"), "n_evals": meta.get("n_evals"), "n_failed": meta.get("n_failed"),
            "best_fitness": best.get("fitness"), "params": best.get("params", {}),
            "metrics": best.get("metrics", {}), "evaluation": best.get("evaluation", {}),
            "wall_s": meta.get("timing", {}).get("wall_s"), "stop_reason": meta.get("stop_reason", ""),
            "created": meta.get("created")}


def _md_table(rows: list[tuple[str, Any]], head=("name", "value")) -> str:
    out = [f"| {head[0]} | {head[1]} |", "|---|---|"]
    for k, v in rows:
        if isinstance(v, float):
            v = f"{v:.6g}"
        out.append(f"| {k} | {v} |")
    return "\n".join(out)


def write_run_report(run_dir: Path) -> Path:
    """Write ``report.md`` (and ``figures/convergence.png``) for a run directory."""
    run_dir = Path(run_dir)
    s = run_summary(run_dir)
    conv_png = plot_convergence(run_dir)
    lines = [f"# Run {s['run']}", "",
             f"Status **{s['status']}** ({s['stop_reason']}); optimizer `{s['optimizer']}`, seed {s['seed']}, "
             f"{s['n_evals']} evaluations ({s['n_failed']} failed), {s['wall_s']:.1f} s wall.", "",
             f"Best fitness: **{s['best_fitness']:.6g}**", "", "## Best parameters", "",
             _md_table(list(s["params"].items()), ("parameter", "value")), ""]
    if s["metrics"]:
        lines += ["## Metrics of the best candidate (tuning data)", "",
                  _md_table(list(s["metrics"].items()), ("metric", "value")), ""]
    ev = s["evaluation"]
    if ev:
        tables = ev.get("tables_md")
        lines += ["## Evaluation", ""]
        if tables:
            lines += [tables, ""]
        flat = [(k, v) for k, v in ev.items() if not isinstance(v, (dict, list)) and k != "tables_md"]
        if flat:
            lines += [_md_table(flat, ("metric", "value")), ""]
    lines += ["## Figures", "", f"![convergence](figures/{conv_png.name})", ""]
    for png in sorted((run_dir / "figures").glob("*.png")):
        if png.name != conv_png.name:
            lines += [f"![{png.stem}](figures/{png.name})", ""]
    path = run_dir / "report.md"
    path.write_text("\n".join(lines))
    return path
