"""``tuner dashboard [DIR]``: DIR/index.html, every run and sweep under DIR, sortable, filterable, compared
side by side."""

from __future__ import annotations

import argparse
from pathlib import Path

from tuner.commands.common import UsageError
from tuner.dashboard import collect_runs, write_dashboard


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("path", nargs="?", default="runs", help="folder of runs (default: runs)")


def run(a: argparse.Namespace) -> int:
    path = Path(a.path)
    if not path.is_dir():
        raise UsageError(f"{path}: not a folder (expected a folder of run directories, e.g. runs)")
    if not collect_runs(path):
        raise UsageError(f"{path}: no run or sweep directory in it (nor up to 4 levels down)")
    print(write_dashboard(path))
    return 0
