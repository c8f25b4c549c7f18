"""``tuner sweep SWEEP``: run many jobs (configs x overrides x seeds) and write one report."""

from __future__ import annotations

import argparse
import sys

from tuner.sweep import collect, run_sweep, summary_text


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("sweep", help="sweep YAML file")
    p.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE",
                   help="override a value of every job, after the sweep's variants and grid, e.g. "
                        "optimizer.generations=5 (repeatable)")
    p.add_argument("--dir", help="sweep directory (default: runs/sweeps/<name>)")
    p.add_argument("--jobs", type=int, help="concurrent jobs (default: from the sweep file, else 1)")
    p.add_argument("-q", "--quiet", action="store_true")
    p.add_argument("--no-report", action="store_true", help="no reports, the jobs' nor the sweep's (results.csv and "
                                                            "summary.csv are written; `tuner report DIR` later)")


def run(a: argparse.Namespace) -> int:
    res = run_sweep(a.sweep, sweep_dir=a.dir, jobs=a.jobs, quiet=a.quiet, report=not a.no_report,
                    overrides=getattr(a, "overrides", []))
    if res.get("interrupted"):
        print(f"sweep interrupted; run the same command again to continue: {res['dir']}", file=sys.stderr)
        return 1
    print(summary_text(collect(res["dir"]), res["dir"]))
    print(f"sweep directory: {res['dir']}")
    if res["report"] is not None:
        print(f"report: {res['report']}")
    return 0 if res["ok"] else 1
