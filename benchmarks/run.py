"""Run the benchmark suite: ``python -m benchmarks.run --full|--smoke [--only NAME ...] [--out DIR]``.

Benchmarks (one module each): ``filters`` (filter throughput against ahrs, imufusion, VQF),
``closed_loop`` (WMP simulations per second, thesis-size PSO run), ``parallel`` (speed-up on 2
workers, engine overhead, peak memory) and ``optimizers`` (quality per evaluation against pyswarms,
Optuna, scipy DE, random search) and ``broad_cv`` (leave-one-group-out CV of every ``configs/broad_*.yaml``
on the shared BROAD trials, skipped without the data) and ``pid_benchmark`` (PID tuned by tuner against the
AMIGO and SIMC rules on Åström and Hägglund's benchmark plants; also ``benchmarks/results/pid_benchmark.md``),
``robust_control`` (controllers tuned on the nominal plant against tuned on an uncertain plant's model set,
scored on 200 held-out perturbed plants; also ``benchmarks/results/robust_control.md``),
``mujoco`` (MuJoCo plants: evaluations per second and the share in MuJoCo, a balancing LQR on held-out perturbed
models; ``benchmarks/results/mujoco.md``) and ``mujoco_wmp`` (the thesis's pendulum as a MuJoCo model against
our 8-state model; ``benchmarks/results/mujoco_wmp.md``); both skipped without the mujoco extra.
Each writes ``<out>/<name>.json`` with the machine facts; the run writes ``<out>/SUMMARY.md`` with a table
per benchmark, targets marked pass/FAIL, and curves as PNG.

``--full`` writes to ``benchmarks/results/`` (committed); ``--smoke`` uses tiny sizes and writes to
a temporary directory unless ``--out`` is given. Peer libraries are not dependencies of the project:

    pip install ahrs imufusion vqf pyswarms optuna cmaes

A peer that is not installed is skipped and reported as missing.
"""

from __future__ import annotations

import argparse
import importlib
import os
import sys
import tempfile
import time
import traceback
from pathlib import Path

from benchmarks.common import PEERS, RESULTS_DIR, fmt, machine_facts, md_table, peer, write_result

BENCHMARKS = ["filters", "closed_loop", "parallel", "optimizers", "broad_cv", "pid_benchmark", "robust_control",
              "mujoco", "mujoco_wmp"]
INSTALL_HINT = "pip install ahrs imufusion vqf pyswarms optuna cmaes"


def _summary(out: Path, sections: list[tuple[str, dict]], facts: dict, smoke: bool, wall: float) -> Path:
    lines = ["# Benchmark summary", "",
             f"{'Smoke run (tiny sizes, numbers meaningless)' if smoke else 'Full run'}, {facts['utc']}, "
             f"commit `{facts['git_commit'][:10]}`.",
             f"Machine: {facts['cpu']}, {facts['cores']} cores, load average (1/5/15 min) at the end "
             f"{', '.join(f'{x:.2f}' for x in facts['load_avg_1_5_15'] or [])}; Python {facts['python']}; "
             + ", ".join(f"{k} {v}" for k, v in facts["versions"].items() if v) + ".",
             f"Wall time of the benchmarks {wall / 60:.1f} min (sum of the sections). The machine is shared: "
             "ratios measured in one run are meaningful, absolute rates less so.", ""]
    all_targets = []
    for name, res in sections:
        for t in res.get("targets", []):
            all_targets.append([name, t["target"], t["value"], "pass" if t["pass"] else "FAIL"])
    if all_targets:
        lines += ["## Targets", "", md_table(["benchmark", "target", "value", "verdict"], all_targets), ""]
    for name, res in sections:
        lines += [f"## {name}", ""]
        if "error" in res:
            lines += [f"Failed: `{res['error']}`", ""]
            continue
        lines += [f"Wall time {fmt(res.get('seconds'))} s.", "", res.get("markdown", ""), ""]
        for title, fig in sorted(res.get("figures", {}).items()):
            lines.append(f"![{title}]({fig})")
        lines.append("")
    path = out / "SUMMARY.md"
    path.write_text("\n".join(lines))
    return path


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m benchmarks.run", description=__doc__.splitlines()[0])
    mode = ap.add_mutually_exclusive_group(required=True)
    mode.add_argument("--full", action="store_true", help="full sizes (about 25 min on 2 cores, plus 5-10 min per "
                      "BROAD config for broad_cv)")
    mode.add_argument("--smoke", action="store_true", help="tiny sizes, to check the suite works")
    ap.add_argument("--only", nargs="+", choices=BENCHMARKS, help="run only these benchmarks")
    ap.add_argument("--summary-only", action="store_true",
                    help="run nothing: rebuild SUMMARY.md from the results stored in the output directory (e.g. "
                         "after benchmarks.optimizers_merge)")
    ap.add_argument("--out", type=Path, default=None, help="output directory")
    ap.add_argument("--n-jobs", type=int, default=2, help="worker processes where a benchmark uses them")
    args = ap.parse_args(argv)
    if args.summary_only and args.only:
        ap.error("--summary-only runs nothing; leave out --only")
    smoke = bool(args.smoke)
    out = args.out or (Path(tempfile.gettempdir()) / "tuner-bench-smoke" if smoke else RESULTS_DIR)
    out.mkdir(parents=True, exist_ok=True)
    root = str(Path(__file__).resolve().parent.parent)
    os.environ["PYTHONPATH"] = os.pathsep.join([root, *filter(None, [os.environ.get("PYTHONPATH")])])
    to_run = [] if args.summary_only else (args.only or BENCHMARKS)
    missing = [pip for mod, pip in PEERS.items() if to_run and peer(mod) is None]
    if missing:
        print(f"peers not installed, skipped: {', '.join(missing)}  (to compare: {INSTALL_HINT})", flush=True)
    sections = []
    for name in to_run:
        print(f"[bench] {name} ...", flush=True)
        t = time.perf_counter()
        try:
            mod = importlib.import_module(f"benchmarks.{name}")
            kwargs = {"smoke": smoke, "n_jobs": args.n_jobs}
            if name == "optimizers":
                kwargs["out_dir"] = out
            res = mod.run(**kwargs)
        except Exception as exc:  # one broken benchmark must not lose the others
            traceback.print_exc()
            res = {"error": f"{type(exc).__name__}: {exc}", "results": {}, "targets": []}
        res["seconds"] = time.perf_counter() - t
        path = write_result(name, {"mode": "smoke" if smoke else "full", **res}, out)
        print(f"[bench] {name}: {res['seconds']:.1f} s -> {path}", flush=True)
        sections.append((name, res))
    if args.only or args.summary_only:  # keep the other benchmarks' latest results in the summary
        import json

        ran = dict(sections)
        sections = []
        for name in BENCHMARKS:
            if name in ran:
                sections.append((name, ran[name]))
            elif (out / f"{name}.json").exists():
                prev = json.loads((out / f"{name}.json").read_text())
                if prev.get("mode") == ("smoke" if smoke else "full"):
                    prev["markdown"] = f"(from an earlier run, {prev['machine']['utc']})\n\n" + prev.get("markdown", "")
                    sections.append((name, prev))
    if not sections:  # --summary-only on a directory without results: keep whatever SUMMARY.md is there
        print(f"error: {out}: no stored {'smoke' if smoke else 'full'} benchmark results to summarise",
              file=sys.stderr)
        return 2
    summary = _summary(out, sections, machine_facts(), smoke, sum(float(r.get("seconds") or 0) for _, r in sections))
    print(f"[bench] summary: {summary}")
    return 1 if any("error" in r for _, r in sections) else 0


if __name__ == "__main__":
    sys.exit(main())
