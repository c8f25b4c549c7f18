"""``tuner verify-c RUN_DIR``: compile the run's exported C, score it next to the model (the objective's
``verify_c`` hook)."""

from __future__ import annotations

import argparse
import math
import sys

from tuner.commands.common import UsageError
from tuner.export import verify_c
from tuner.objective import ToolError


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("run_dir")
    p.add_argument("--data", help="YAML file with a `data` list replacing the run's data")
    p.add_argument("--precision", default="double", choices=["double", "float"])
    p.add_argument("--fast-math", action="store_true", help="compile with -O2 -ffast-math (default: -O2)")


def run(a: argparse.Namespace) -> int:
    try:
        out = verify_c(a.run_dir, a.data, a.precision, ("-O2", "-ffast-math") if a.fast_math else ("-O2",))
    except (ToolError, FileNotFoundError) as exc:  # no compiler, or one that failed: one line naming it
        raise UsageError(str(exc)) from None
    for w in out.get("warnings", []):
        print(f"warning: {w}", file=sys.stderr)
    py, c = out["python"], out["c"]
    compiler = f" with {out['compiler']}" if out.get("compiler") else ""
    print(f"{out['name']} compiled{compiler} ({out['precision']}, {' '.join(out['flags'])}): "
          f"fitness model {py.fitness:.6g}, C {c.fitness:.6g} (C - model {c.fitness - py.fitness:.3g}); "
          f"time model {out['seconds']['python']:.2f} s, C {out['seconds']['c']:.2f} s")
    angles = out.get("max_angle_rad") or {}
    diffs = out.get("max_abs_diff") or {}  # a closed loop: the trajectories of the model and of the C
    for rec, m in py.recordings.items():
        keys = [k for k, v in m.items() if isinstance(v, (int, float)) and (k.endswith("deg") or diffs)]
        vals = "  ".join(f"{k} model {m[k]:.6g} C {c.recordings[rec][k]:.6g}" + (
            f" ({c.recordings[rec][k] - m[k]:+.2g})" if math.isfinite(c.recordings[rec][k] - m[k]) else "")
            for k in keys)
        angle = f"max angle {angles[rec]:.3g} rad  " if rec in angles else ""
        diff = f"max |C - model| {diffs[rec]:.3g} (states, outputs, commands)  " if rec in diffs else ""
        print(f"  {rec}: {angle}{diff}{vals}")
    if out.get("agrees") is False:
        print(f"error: the C's closed loop leaves the model's by more than {out.get('tolerance', 0):.3g} (relative)",
              file=sys.stderr)
        return 1
    return 0 if not (py.failed or c.failed) else 1
