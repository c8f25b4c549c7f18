"""Merge optimiser-benchmark runs made one real problem at a time into one ``optimizers.json``.

``python -m benchmarks.optimizers_merge --out DIR RUN.json ... [--functions-from OLD.json]``

On a shared machine a full run of the real problems takes most of an hour; running each problem as its
own ``python -m benchmarks.optimizers --real-only --problems NAME`` keeps every finished problem if a
later one is interrupted. Each problem's threshold (1 % above the best fitness any method found) only
depends on that problem's runs, so merging changes no number. ``--functions-from`` carries the test
function rows of an earlier full result over (named as such in the text). The verdicts, targets and
tables are rebuilt by :func:`benchmarks.optimizers.report`, the curves redrawn from the stored quartiles.
"""

from __future__ import annotations

import argparse
import json
import math
from pathlib import Path
from typing import Any

from benchmarks.optimizers import FUNCTIONS, _fmt_load, _plot, _verdict, publish, report

__all__ = ["merge"]


def _inf(v: Any) -> Any:
    """JSON stores inf as null; the analyses compare numbers."""
    if v is None:
        return math.inf
    if isinstance(v, list):
        return [math.inf if x is None else x for x in v]
    return v


def _load_analyses(data: dict[str, Any]) -> dict[str, Any]:
    out = data["results"]["problems"]
    for a in out.values():
        for v in a["methods"].values():
            v["evals_to_1pct_median"] = _inf(v["evals_to_1pct_median"])
            v["evals_to_1pct"] = _inf(v["evals_to_1pct"])
    return out


def merge(runs: list[Path], out_dir: Path, functions_from: Path | None = None) -> dict[str, Any]:
    """The merged result (as :func:`benchmarks.optimizers.run` returns it); writes the curves to ``out_dir``."""
    datas = [json.loads(Path(p).read_text()) for p in runs]
    Path(out_dir).mkdir(parents=True, exist_ok=True)
    analyses: dict[str, Any] = {}
    per_run = []
    for d in datas:
        res = d["results"]
        a = {k: v for k, v in _load_analyses(d).items() if k not in FUNCTIONS}
        analyses.update(a)
        per_run.append(f"{', '.join(a)}: {res['wall_s']:.0f} s, load {_fmt_load(res.get('load_start'))} -> "
                       f"{_fmt_load(res.get('load_end'))} (finished {d['machine']['utc']})")
    verdicts = {k: _verdict(a) for k, a in analyses.items()}
    figures = {k: f for k, a in analyses.items() if (f := _plot(k, a, out_dir))}
    note = ""
    if functions_from is not None:
        old = json.loads(Path(functions_from).read_text())
        funs = {k: v for k, v in _load_analyses(old).items() if k in FUNCTIONS}
        analyses.update(funs)
        figures.update({k: f"quality_{k}.png" for k in funs})
        note = (f"Test-function rows are from the earlier full run of {old['machine']['utc']} "
                f"(commit {old['machine']['git_commit'][:10]}), not re-run.")
    first, last = datas[0]["results"], datas[-1]["results"]
    meta = {"real_budget": 120, "real_pop": 12, "fun_dim": 5, "fun_budget": 300, "fun_pop": 20,
            "n_seeds": len(first["seeds"]), "wall": sum(d["results"]["wall_s"] for d in datas), "n_jobs": 2,
            "load_start": first.get("load_start"), "load_end": last.get("load_end"),
            "missing": sorted({m for d in datas for m in d["results"]["missing_peers"]}),
            "skipped": {k: v for d in datas for k, v in d["results"]["skipped"].items()},
            "methods": first["methods"]}
    lines, targets, fun_cmp, n_pass = report(analyses, verdicts, meta)
    lines.insert(1, "One process per problem, in this order (wall time, load average 1/5/15 min at start -> end):\n\n"
                 + "\n".join(f"- {r}" for r in per_run) + ("\n\n" + note if note else ""))
    return {"results": {"problems": analyses, "verdicts": verdicts, "functions_vs_pyswarms": fun_cmp,
                        "missing_peers": meta["missing"], "skipped": meta["skipped"], "wall_s": meta["wall"],
                        "n_pass_real": n_pass, "seeds": first["seeds"], "methods": meta["methods"],
                        "load_start": meta["load_start"], "load_end": meta["load_end"], "runs": per_run},
            "figures": figures, "markdown": "\n".join(lines), "targets": targets, "seconds": meta["wall"]}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m benchmarks.optimizers_merge", description=__doc__.splitlines()[0])
    ap.add_argument("runs", nargs="+", type=Path, help="optimizers.json of each per-problem run")
    ap.add_argument("--out", type=Path, required=True, help="directory for the merged optimizers.json and curves")
    ap.add_argument("--functions-from", type=Path, help="an earlier full optimizers.json whose test functions to keep")
    args = ap.parse_args(argv)
    res = merge(args.runs, args.out, args.functions_from)
    publish(res, Path(args.out), "full")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
