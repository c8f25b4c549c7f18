"""``tuner evaluate TARGET``: score parameters without tuning (default: a run's best)."""

from __future__ import annotations

import argparse
import json
import sys

from tuner.rescore import evaluate_target


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("target", help="a run directory or a config file")
    p.add_argument("--params", help="YAML file with parameters (a best.yaml works)")
    p.add_argument("--data", help="YAML file with a `data` list (or mapping) replacing the config's data")
    p.add_argument("--json", action="store_true", help="print {fitness, recordings: {...}} as JSON")


def run(a: argparse.Namespace) -> int:
    out = evaluate_target(a.target, params_file=a.params, data_file=a.data)
    for w in out.get("warnings", []):
        print(f"warning: {w}", file=sys.stderr)
    if a.json:
        print(json.dumps(out, indent=1, default=float))
        return 0
    print(f"fitness: {out['fitness']:.6g}")
    for rec, metrics in out.get("recordings", {}).items():
        vals = "  ".join(f"{k}={v:.4g}" for k, v in metrics.items() if isinstance(v, (int, float)))
        print(f"  {rec}: {vals}")
    dep = out.get("deployment") or {}
    if dep:  # every value of the scored filter/controller (searched, fixed, defaults)
        print(f"deployed {dep['kind']} {dep['name']}: " + ", ".join(f"{k}={v!r}" for k, v in dep["values"].items()))
        for note in dep.get("notes") or []:  # the scores above used the run's scoring settings (a truth start)
            print(f"note: the scores above use the run's scoring settings; {note}")
    return 0
