"""Measure the seeds' claims from ``configs/papers/`` and write ``docs/papers.md`` and ``docs/papers.json``.

One run measures every claim: for each row the paper's number as printed, ours over at least five
seeds, the per-seed check of the paper's sentence and the verdict that
:func:`benchmarks.papers_common.verdict` computes from them by the rules printed at the top of the
page; each claim's verdict is its weakest row's. The per-seed values go to ``docs/papers.json`` and
the page is drawn from that record alone (:mod:`benchmarks.papers_page`). The header names the wall
and CPU time, the commit (``+dirty`` when the tree had changes) and the machine of that run. Nothing
on the page is edited by hand: regenerating it is ``make papers``.

    python -m benchmarks.papers            # reduced budgets (make papers; sized for under 15 min on 2 cores)
    python -m benchmarks.papers --full     # the papers' budgets (make papers-full; hours)
    python -m benchmarks.papers --smoke    # tiny budgets and two seeds, same claims and rows (the tests)
"""

from __future__ import annotations

import argparse
import datetime as _dt
import os
import platform
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path

from benchmarks.papers_attitude import ccf_claims, faekf_claims, qraukf_claims
from benchmarks.papers_common import Claim
from benchmarks.papers_control import control_claims
from benchmarks.papers_page import dump, load, record, render
from benchmarks.papers_runs import PAPERS, ROOT, config_raw, cpu_seconds, objective, section
from benchmarks.papers_tilt import tilt_claims

__all__ = ["Budget", "BUDGETS", "measure", "preflight", "commit_id", "machine", "main"]


@dataclass(frozen=True)
class Budget:
    """Budgets of one page.

    Attributes
    ----------
    name : str
        ``smoke``, ``reduced`` (``make papers``) or ``full`` (``make papers-full``).
    seeds : tuple of int
        Tuning seeds (and sensor-noise seeds where a row varies those); at least five except for the smoke
        test (a row over fewer seeds cannot be reproduced).
    ccf_evals : int
        Evaluations of the NCF config's ``auto`` method per tuning.
    tilt : (int, int) or None
        PSO population x generations of the thesis's tilt filters; None: the thesis's own sizes
        (30 x 30 KF and AKF, 20 x 20 Mahony, 10 x 10 Madgwick).
    faekf : (int, int)
        PSO of the FAEKF and EKF configs.
    control : (int, int)
        PSO of the pendulum's fuzzy and PID configs (the thesis: 150 x 150 and 40 x 40).
    timing_rounds : int
        Timing rounds of the CCF's speed rows.
    light : bool
        Tuning runs in this process (same results): the smoke budget's, whose few evaluations per run cost
        less than starting workers (which compile the pendulum's kernel again: it is not cached on disk).
    """

    name: str
    seeds: tuple[int, ...]
    ccf_evals: int
    tilt: tuple[int, int] | None
    faekf: tuple[int, int]
    control: tuple[int, int]
    timing_rounds: int = 5
    light: bool = False

    def describe(self) -> str:
        tilt = "the thesis PSO sizes" if self.tilt is None else f"PSO {self.tilt[0]} x {self.tilt[1]}"
        return (f"NCF {self.ccf_evals} evaluations of `auto`, tilt filters {tilt}, FAEKF/EKF PSO {self.faekf[0]} x "
                f"{self.faekf[1]}, pendulum PSO {self.control[0]} x {self.control[1]} (thesis 150 x 150), "
                f"{self.timing_rounds} timing rounds")


BUDGETS = {
    "smoke": Budget("smoke", (1, 2), 8, (3, 2), (3, 2), (4, 2), timing_rounds=2, light=True),
    "reduced": Budget("reduced", (1, 2, 3, 4, 5), 300, (10, 10), (10, 8), (30, 30)),
    "full": Budget("full", (1, 2, 3, 4, 5), 300, None, (30, 30), (150, 150)),
}


def preflight() -> None:
    """Build every paper config's objective and look up every filter the rows time, before any tuning: a
    face that moved elsewhere fails here in seconds, not after minutes of measurement."""
    from benchmarks.papers_attitude import _per_rec
    from benchmarks.papers_control import _sec22, _table_24
    from objectives.attitude.filters import get_filter
    from tuner.api import tune  # noqa: F401  (every tuning row runs through it)

    for cfg in sorted(p.name for p in PAPERS.glob("*.yaml")):
        if "objective" in config_raw(cfg):  # not a sweep file
            objective(section(cfg))
    for name in ("ccf", "ncf", "lcf", "ekf"):
        get_filter(name)
    _per_rec(objective(section("ncf_narkhede.yaml")), {})  # the per-recording metrics the attitude rows read
    obj = _sec22("flc", 0)
    _table_24(obj, obj.default_params())  # the metrics and traces the chapter-2 rows read


def measure(budget: Budget, runs: Path) -> list[Claim]:
    """Every claim, in page order."""
    s, j = budget.seeds, budget.light
    return (ccf_claims(budget.ccf_evals, s, runs, j, budget.timing_rounds) + qraukf_claims()
            + tilt_claims(budget.tilt, s, runs, j) + faekf_claims(budget.faekf, s, runs, j)
            + control_claims(budget.control, s, runs, j))


def _git(*args: str) -> str:
    return subprocess.run(["git", *args], cwd=ROOT, capture_output=True, text=True, check=True).stdout.strip()


def commit_id() -> str:
    """``git rev-parse HEAD``, with ``+dirty`` when the working tree has changes."""
    try:
        head = _git("rev-parse", "HEAD")
        dirty = bool(_git("status", "--porcelain", "--untracked-files=no"))
    except (OSError, subprocess.CalledProcessError):
        return "unknown (not a git checkout)"
    return head + ("+dirty" if dirty else "")


def machine() -> str:
    """CPU model, core count, OS and Python of this machine, with the load at the start."""
    model = platform.processor() or platform.machine()
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                model = line.partition(":")[2].strip()
                break
    except OSError:
        pass
    load = f", load average {os.getloadavg()[0]:.1f} at the start" if hasattr(os, "getloadavg") else ""
    return (f"{model}, {os.cpu_count()} logical CPUs, {platform.system()} {platform.release()}, "
            f"Python {platform.python_version()}{load}")


def main(argv: list[str] | None = None) -> int:
    """Command line: measure every claim, write docs/papers.json and docs/papers.md (``--out`` for another
    page; the JSON goes beside it with the suffix ``.json``)."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    g = ap.add_mutually_exclusive_group()
    g.add_argument("--smoke", action="store_true", help="tiny budgets, two seeds (tests)")
    g.add_argument("--full", action="store_true", help="the papers' budgets (hours)")
    ap.add_argument("--out", type=Path, default=ROOT / "docs" / "papers.md")
    ap.add_argument("--runs", type=Path, default=ROOT / "runs" / "papers")
    args = ap.parse_args(argv)
    if args.out.suffix != ".md" or not args.out.parent.is_dir():
        print(f"error: --out: {args.out}: need a .md file in an existing folder", file=sys.stderr)
        return 2
    budget = BUDGETS["smoke" if args.smoke else "full" if args.full else "reduced"]
    commit, host = commit_id(), machine()
    started = _dt.datetime.now(_dt.UTC).strftime("%Y-%m-%d %H:%M:%S UTC")
    t0 = time.perf_counter()
    preflight()
    args.runs.mkdir(parents=True, exist_ok=True)
    claims = measure(budget, args.runs)
    wall = time.perf_counter() - t0
    cpu_self, cpu_kids = cpu_seconds()
    prov = {"budget": budget.name, "started": started, "wall_s": round(wall, 1), "cpu_s": round(cpu_self + cpu_kids, 1),
            "cpu_self_s": round(cpu_self, 1), "cpu_children_s": round(cpu_kids, 1), "commit": commit,
            "machine": host, "seeds": ", ".join(map(str, budget.seeds)), "budgets": budget.describe()}
    dump(record(claims, prov), args.out.with_suffix(".json"))
    args.out.write_text(render(*load(args.out.with_suffix(".json"))))  # the page from the record alone
    print(f"wrote {args.out} and {args.out.with_suffix('.json').name}: {len(claims)} claims, "
          f"{sum(len(c.rows) for c in claims)} rows; wall {wall:.0f} s, CPU {cpu_self + cpu_kids:.0f} s "
          f"(this process {cpu_self:.0f} s, workers {cpu_kids:.0f} s)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
