"""``tuner describe NAME``: parameters, bounds, units and equations of any name a config can use (an
optimiser, an objective kind, or what a kind declares: filter, controller, metric, data source)."""

from __future__ import annotations

import argparse

from tuner.commands.common import UsageError
from tuner.describe import UnknownName, describe, format_text
from tuner.export_formats import to_json


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("name", help="a name `tuner list` prints, e.g. ekf, pso, euler_mse_geomean, bench6dof")
    p.add_argument("--json", action="store_true", help="strict JSON: {name, found: [descriptions]}")


def run(a: argparse.Namespace) -> int:
    try:
        found = describe(a.name)
    except UnknownName as exc:
        raise UsageError(str(exc)) from None
    if a.json:
        print(to_json({"name": a.name, "found": found}))  # strict JSON, inf as "inf" (nonfinite_paths)
    else:
        print("\n\n".join(format_text(d) for d in found))
    return 0
