"""``tuner report PATH``: (re)write the report of a sweep or a run directory, or the dashboard of a folder of
runs."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from tuner.commands import dashboard
from tuner.commands.common import UsageError
from tuner.replay import verify_history
from tuner.report import write_run_report
from tuner.rundir import RunDir
from tuner.sweep import write_missing_job_reports, write_sweep_report


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("path")


def run(a: argparse.Namespace) -> int:
    path = Path(a.path)
    if (path / "sweep.yaml").exists():
        write_missing_job_reports(path)  # jobs of a sweep run with --no-report
        print(write_sweep_report(path))
    elif (path / "meta.json").exists() or (path / "config.yaml").exists():
        if (path / "meta.json").exists():
            note = verify_history(RunDir(path))  # RunError naming an edited row
            if note:
                print(f"note: {note}", file=sys.stderr)
        print(write_run_report(path))  # RunError naming the file if one is corrupt
    elif path.is_dir():
        return dashboard.run(a)
    else:
        raise UsageError(f"{path}: not a run or sweep directory, nor a folder of runs")
    return 0
