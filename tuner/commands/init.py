"""``tuner init NAME``: write a commented starter job for a filter or controller (the objective packages'
``tuner.starters`` entry points)."""

from __future__ import annotations

import argparse

from tuner.commands.common import UsageError
from tuner.starter import StarterError, write_starter


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("name", help="a filter or controller `tuner list` prints, e.g. madgwick, pid")
    p.add_argument("-o", "--output", help="file to write (default: NAME.yaml); an existing file is never overwritten")


def run(a: argparse.Namespace) -> int:
    try:
        out = write_starter(a.name, a.output)
    except StarterError as exc:
        raise UsageError(str(exc)) from None
    print(f"wrote {out}; run it with: tuner run {out}")
    return 0
