"""``tuner list [WHAT]``: what can be named in a config (optimisers, objective kinds, the sections the
kinds list), or the runs of a directory."""

from __future__ import annotations

import argparse
from pathlib import Path

from tuner.commands.common import UsageError
from tuner.optimizers import OPTIMIZERS
from tuner.registry import REGISTRY
from tuner.runinfo import list_runs


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("what", nargs="?", default="all",
                   help="all, optimizers, objectives, runs, or a section an objective kind lists "
                        "(filters, controllers, functions, metrics, data)")
    p.add_argument("--dir", default="runs", help="runs directory for `list runs` (default: runs)")


def run(a: argparse.Namespace) -> int:
    what = a.what
    if what == "runs":
        print(list_runs(Path(a.dir)))
        return 0
    if what in ("all", "optimizers"):
        print("optimizers:")
        for name, cls in sorted(OPTIMIZERS.items()):
            doc = (cls.__doc__ or "").strip().splitlines()[0]
            print(f"  {name:10s} {doc}")
    catalog = REGISTRY.catalog() if what not in ("optimizers", "objectives") else {}
    if what not in ("all", "optimizers", "objectives", *catalog):
        raise UsageError(f"list: unknown section {what!r}; allowed: all, optimizers, objectives, runs, "
                         f"{', '.join(sorted(catalog))}")
    if what in ("all", "objectives"):
        print("objective kinds:")
        for name, source in REGISTRY.kinds().items():
            print(f"  {name:12s} {source}")
    for section in catalog:
        if what not in ("all", section):
            continue
        for kind, sections in REGISTRY.catalogs().items():  # a section several kinds list: one line per kind
            if section in sections:
                print(f"{section} (objective.kind: {kind}):")
                print("  " + (", ".join(sections[section]) or "-"))
    if what in ("all", *catalog):
        print("`tuner describe NAME` shows the parameters, bounds, units and equations of any name above.")
    return 0
