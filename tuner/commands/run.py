"""``tuner run CONFIG``: tune a job from a YAML config (a sweep file runs as a sweep)."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from tuner.commands import sweep
from tuner.commands.common import UsageError
from tuner.config import load_config
from tuner.failures import failure_groups
from tuner.records import RunError
from tuner.repeats import run as run_job
from tuner.run import RunResult
from tuner.rundir import RunDir
from tuner.spread import spread_lines
from tuner.sweep import is_sweep_file
from tuner.verdict import defaults_verdict

DESCRIPTION = "Run a tuning job and store it in its own run directory."


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("config", help="job YAML file")
    p.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE",
                   help="override a config value, e.g. optimizer.population=40 (repeatable)")
    p.add_argument("--seed", type=int, help="override the seed")
    p.add_argument("--n-jobs", type=int, help="override parallel.n_jobs")
    p.add_argument("--repeats", type=int, metavar="N",
                   help="run the job N times, seeds seed .. seed+N-1, and deploy one (held-out score, else the "
                        "median fitness); the spread over the seeds is shown and reported")
    p.add_argument("--run-dir", help="use this run directory instead of runs/<time>-<name>-<hex>")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress lines")
    p.add_argument("--no-report", action="store_true",
                   help="no report, live or final (report.md/.html, figures; `tuner report RUN` writes it later)")


def run(a: argparse.Namespace) -> int:
    if is_sweep_file(a.config):  # a sweep file runs as a sweep (e.g. the demo compares filters)
        if a.seed is not None or a.n_jobs or a.run_dir or a.repeats:
            raise UsageError(f"{a.config}: is a sweep file; --seed/--n-jobs/--run-dir/--repeats apply to job files "
                             "(--set applies to every job of the sweep)")
        return sweep.run(argparse.Namespace(sweep=a.config, dir=None, jobs=None, quiet=a.quiet, no_report=a.no_report,
                                            overrides=a.overrides))
    cfg = load_config(a.config, a.overrides, seed=a.seed, n_jobs=a.n_jobs, repeats=a.repeats)
    return print_result(run_job(cfg, run_dir=a.run_dir, quiet=a.quiet, report=not a.no_report))


def _stored_verdict(run_dir: Path) -> str | None:
    """The verdict of the run's ``best.yaml`` evaluation (validation writes its scores there)."""
    from tuner.rundir import RunDir

    rd = RunDir(run_dir)
    try:
        return defaults_verdict(rd.best().evaluation) if rd.has_best() else None
    except Exception:  # noqa: BLE001 - an unreadable best.yaml is reported where it is read, not here
        return None


def print_result(res: RunResult) -> int:
    """The end of ``run`` and ``resume``: status, best fitness and parameters, where the run is; the exit
    status (1 when the run did not finish or every evaluation failed)."""
    print(f"status: {res.status} ({res.stop_reason})")
    print(f"best fitness: {res.best_fitness:.6g} after {res.n_evals} evaluations")
    for k, v in res.best_params.items():
        print(f"  {k}: {v:.6g}" if isinstance(v, float) else f"  {k}: {v}")
    summary = res.extra.get("summary_table")
    if summary:
        print()
        print(summary)
    verdict = _stored_verdict(res.run_dir)
    if verdict:
        print(f"warning: {verdict}")
    if res.repeats is not None:
        print()
        print("\n".join(spread_lines(res.repeats)))
    print(f"run directory: {res.run_dir}")
    if (res.run_dir / "report.md").exists():
        print(f"report: {res.run_dir / 'report.md'}")
    if res.status == "failed" and res.repeats is not None:
        print(f"error: {res.run_dir}: no repeat to deploy (a repeat whose every evaluation failed is not chosen)",
              file=sys.stderr)
        return 1
    if res.status == "failed":
        print(f"error: {res.run_dir}: every one of {res.n_evals} evaluations failed; "
              f"{failure_summary(res.run_dir)}", file=sys.stderr)
        return 1
    return 0 if res.status == "finished" else 1


def failure_summary(run_dir: Path, top: int = 3) -> str:
    """The most frequent reasons in a run's history (why every evaluation failed), grouped by
    :func:`tuner.failures.failure_groups`: each with the number of evaluations that give it and an example."""
    try:
        errors = [row.get("error", "") for row in RunDir(run_dir).history_rows()]
    except (OSError, RunError):
        return "see history.csv"
    groups = failure_groups(errors)[:top]
    if not groups:
        return "see history.csv"
    return "most common reasons: " + "; ".join(f"{g.example} ({g.count} of {len(errors)} evaluations)"
                                               for g in groups)
