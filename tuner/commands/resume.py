"""``tuner resume RUN_DIR``: continue an interrupted run from its checkpoint."""

from __future__ import annotations

import argparse

from tuner.commands.run import print_result
from tuner.repeats import is_repeated
from tuner.repeats import resume as resume_repeats
from tuner.run import resume


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("run_dir")
    p.add_argument("-q", "--quiet", action="store_true")
    p.add_argument("--no-report", action="store_true", help="write no report, as for `tuner run --no-report`")


def run(a: argparse.Namespace) -> int:
    go = resume_repeats if is_repeated(a.run_dir) else resume
    return print_result(go(a.run_dir, quiet=a.quiet, report=not a.no_report))
