"""``tuner init [NAME]``: write a commented starter job for a filter or controller (the objective packages'
``tuner.starters`` entry points)."""

from __future__ import annotations

import argparse

from tuner.commands.common import UsageError
from tuner.starter import StarterError, starter_names, write_starter


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("name", nargs="?", help="a filter or controller `tuner list` prints, e.g. madgwick, pid "
                   "(without it: the list of starters)")
    p.add_argument("-o", "--output", help="file to write (default: NAME.yaml); an existing file is never overwritten")


def run(a: argparse.Namespace) -> int:
    if a.name is None:
        names = starter_names()
        print("starter jobs (tuner init NAME writes NAME.yaml):")
        for kind in sorted(set(names.values())):
            print(f"  {kind}: " + ", ".join(sorted(n for n, k in names.items() if k == kind)))
        return 0
    try:
        out = write_starter(a.name, a.output)
    except StarterError as exc:
        raise UsageError(str(exc)) from None
    print(f"wrote {out}; run it with: tuner run {out}")
    return 0
