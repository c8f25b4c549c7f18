"""``tuner show PATH``: the summary of a run or a sweep directory (no pandas: it stays light)."""

from __future__ import annotations

import argparse
import json
from dataclasses import asdict
from pathlib import Path

from tuner.bounds import run_warnings
from tuner.commands.common import UsageError
from tuner.replay import verify_history
from tuner.rundir import RunDir
from tuner.runinfo import fmt, run_summary, scores, tuned_system
from tuner.spread import spread_lines
from tuner.sweep import show_sweep
from tuner.verdict import transfer_line


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("path")
    p.add_argument("--json", action="store_true", help="machine-readable output")


def run(a: argparse.Namespace) -> int:
    path = Path(a.path)
    if (path / "sweep.yaml").exists():
        print(show_sweep(path, as_json=a.json))
        return 0
    if not (path / "meta.json").exists() and not (path / "config.yaml").exists():
        raise UsageError(f"{path}: not a run or sweep directory (no meta.json / sweep.yaml)")
    note = verify_history(RunDir(path))  # RunError naming an edited row
    chosen = RunDir(path).chosen_repeat()
    if chosen is not None:  # a repeated run deploys its chosen repeat's best: that repeat's history is checked too
        note = verify_history(RunDir(chosen)) or note
    s = run_summary(path)  # RunError naming the file if meta.json/best.yaml is corrupt
    warnings = run_warnings(path)
    rep = RunDir(path).repeats()
    if a.json:
        extra = {"repeats": rep.to_doc()} if rep is not None else {}
        print(json.dumps({**s, "warnings": [asdict(w) for w in warnings], **extra}, indent=1, default=str))
        return 0
    print(f"run:        {s['run']}")
    print(f"status:     {s['status']} ({s['stop_reason']})")
    print(f"optimizer:  {s['optimizer']}  seed {s['seed']}")
    print(f"evals:      {s['n_evals']} ({s['n_failed']} failed), {s['wall_s'] or 0:.1f} s")
    _show_scores(path, s["best_fitness"], s["evaluation"], s["params"])
    if s["evaluation"].get("summary_table"):
        print()
        print(s["evaluation"]["summary_table"])
    if rep is not None:
        print("\n".join(spread_lines(rep)))
    for w in warnings:
        print(f"warning: {w.message}")
    if note:
        print(f"note: {note}")
    return 0


def _show_scores(path: Path, fit: float | None, evaluation: dict, params: dict) -> None:
    """What was tuned; best, test and CV scores with the gap, each with the defaults'; searched and fixed values."""
    t = tuned_system(path)
    print(f"tuned:      {t['kind']} {t['name']}".rstrip())
    sc = scores(evaluation)
    dflt = sc.get("defaults_fitness")
    print(("best:       " + fmt(float(fit)) if fit is not None else "best:       -")
          + (f" (defaults {fmt(dflt)})" if dflt is not None else ""))
    if "test_fitness" in sc:
        d = sc.get("defaults_test_fitness")
        print(f"test:       {fmt(sc['test_fitness'])}" + (f" (defaults {fmt(d)})" if d is not None else ""))
    if "cv_fitness" in sc:
        d, gap = sc.get("defaults_cv_fitness"), sc.get("cv_gap")
        print(f"cv:         {fmt(sc['cv_fitness'])}" + (f" (defaults {fmt(d)})" if d is not None else "")
              + (f"; tuning score {fmt(sc['tuning_score'])}" if "tuning_score" in sc else "")
              + (f", gap {gap:+.3g}" + (" LARGE" if sc.get("cv_gap_large") else "") if gap is not None else ""))
    try:
        transfer = transfer_line(RunDir(path).validation())
    except Exception:  # noqa: BLE001 - a damaged validation.json only loses the transfer line
        transfer = ""
    if transfer:
        print(f"            {transfer}")
    searched = [k for k in params if k in t["searched"]] or [k for k in params if k not in t["fixed"]]
    for title, items in (("searched:", [(k, params[k]) for k in searched]), ("fixed:", list(t["fixed"].items()))):
        if items:
            print(title)
        for k, v in items:
            print(f"  {k:24s} {fmt(v)}")
    for note in t.get("notes", []):  # e.g. the scoring-only truth start the deployment replaced
        print(f"note:       {note}")
