"""``tuner compare RUN_DIR...``: two or more runs side by side (parameters and metrics)."""

from __future__ import annotations

import argparse
from pathlib import Path

import pandas as pd

from tuner.render import fmt_num
from tuner.runinfo import run_summary, scores, tuned_system


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("run_dirs", nargs="+")


def run(a: argparse.Namespace) -> int:
    cols = {}
    for d in a.run_dirs:
        s = run_summary(Path(d))  # RunError naming the file if meta.json/best.yaml is missing or corrupt
        t = tuned_system(Path(d))
        col = {"tuned": f"{t['kind']} {t['name']}".strip(), "status": s["status"], "optimizer": s["optimizer"],
               "seed": s["seed"], "n_evals": s["n_evals"], "best_fitness": s["best_fitness"], **scores(s["evaluation"])}
        col.update({f"param.{k}": v for k, v in s["params"].items() if k not in t["fixed"]})
        col.update({f"fixed.{k}": v for k, v in t["fixed"].items()})
        col.update({f"metric.{k}": v for k, v in s["metrics"].items() if not isinstance(v, (dict, list))})
        cols[s["run"]] = col
    table = pd.DataFrame(cols).map(lambda v: "-" if v is None or (isinstance(v, float) and v != v) else fmt_num(v))
    print(table.to_string())
    return 0
