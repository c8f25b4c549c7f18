"""The ``tuner`` command line.

Exit status: 0 success, 1 a run failed or was interrupted, 2 bad input (config, arguments, run
directory), printed as one line ``error: <file>: <key>: <what is wrong and what is allowed>``.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path
from typing import Any

__all__ = ["main"]

EPILOG = """examples:
  tuner run configs/demo.yaml                      the demo (a sweep file runs as a sweep)
  tuner run configs/ekf_bench6dof.yaml --seed 3 --n-jobs 1   override seed and workers
  tuner run job.yaml --set optimizer.population=40 --set objective.metric=broad_total_rmse
  tuner resume runs/20261122T101500Z-demo-a1b2c3   continue an interrupted run
  tuner show runs/20261122T101500Z-demo-a1b2c3     summary of a run (or a sweep directory)
  tuner export RUN_DIR --format c > tuned.h        best parameters as a C header
  tuner export RUN_DIR --format c-filter --out fw  the tuned filter itself as C99 (fw/<prefix>.h, .c)
  tuner verify-c RUN_DIR                           that C compiled and scored next to the Python model
  tuner evaluate RUN_DIR --data other.yaml --json  score the best parameters on other data
  tuner sweep configs/thesis_tilt_sweep.yaml       many runs and one report
  tuner dashboard runs                             runs/index.html: every run and sweep, sortable, compared
  tuner list                                       optimizers, objectives, filters, controllers, metrics, data
  tuner describe ekf                               parameters, bounds, units and equations of one name
  tuner init madgwick                              write madgwick.yaml, a commented starter job
  tuner demo                                       the packaged demo (EKF vs FAEKF, about two minutes)
"""


class UsageError(Exception):
    pass


def _add_run(sub) -> None:
    p = sub.add_parser("run", help="tune: run a job from a YAML config",
                       description="Run a tuning job and store it in its own run directory.")
    p.add_argument("config", help="job YAML file")
    p.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE",
                   help="override a config value, e.g. optimizer.population=40 (repeatable)")
    p.add_argument("--seed", type=int, help="override the seed")
    p.add_argument("--n-jobs", type=int, help="override parallel.n_jobs")
    p.add_argument("--run-dir", help="use this run directory instead of runs/<time>-<name>-<hex>")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress lines")
    p.add_argument("--no-report", action="store_true",
                   help="no report, live or final (report.md/.html, figures; `tuner report RUN` writes it later)")


def build_parser() -> argparse.ArgumentParser:
    ap = argparse.ArgumentParser(
        prog="tuner", formatter_class=argparse.RawDescriptionHelpFormatter, epilog=EPILOG,
        description="Tune attitude filters and robot controllers by global optimisation "
                    "(PSO, CMA-ES, differential evolution).")
    from tuner._version import __version__

    ap.add_argument("--version", action="version", version=f"tuner {__version__}")
    sub = ap.add_subparsers(dest="command", metavar="COMMAND")
    _add_run(sub)

    p = sub.add_parser("resume", help="continue an interrupted run from its checkpoint")
    p.add_argument("run_dir")
    p.add_argument("-q", "--quiet", action="store_true")
    p.add_argument("--no-report", action="store_true", help="write no report, as for `tuner run --no-report`")

    p = sub.add_parser("show", help="summary of a run or a sweep directory")
    p.add_argument("path")
    p.add_argument("--json", action="store_true", help="machine-readable output")

    p = sub.add_parser("compare", help="two or more runs side by side (parameters and metrics)")
    p.add_argument("run_dirs", nargs="+")

    p = sub.add_parser("list", help="what can be named in a config, or the runs of a directory")
    p.add_argument("what", nargs="?", default="all",
                   help="all, optimizers, objectives, runs, or a section an objective kind lists "
                        "(filters, controllers, functions, metrics, data)")
    p.add_argument("--dir", default="runs", help="runs directory for `list runs` (default: runs)")

    p = sub.add_parser("describe", help="parameters, bounds, units and equations of a filter, controller, "
                                        "optimizer, metric, objective kind or data source")
    p.add_argument("name", help="a name `tuner list` prints, e.g. ekf, pso, euler_mse_geomean, bench6dof")
    p.add_argument("--json", action="store_true", help="strict JSON: {name, found: [descriptions]}")

    p = sub.add_parser("export", help="best parameters as yaml, json, python or a C header")
    p.add_argument("run_dir")
    p.add_argument("--format", default="yaml", choices=["yaml", "json", "python", "c", "c-filter"],
                   help="c-filter: C99 header + source of the tuned filter itself (see --precision, --out)")
    p.add_argument("--precision", default="double", choices=["double", "float"], help="c-filter: arithmetic")
    p.add_argument("--out", default=".", help="c-filter: directory for <prefix>.h and <prefix>.c (default: .)")
    p.add_argument("-o", "--output", help="write to this file instead of standard output")
    p.add_argument("--prefix", help="C identifier prefix, e.g. EKF1 (default: from the run's name); lets two "
                                    "headers be included in one file")

    p = sub.add_parser("verify-c", help="compile a run's exported C filter, score it next to the model")
    p.add_argument("run_dir")
    p.add_argument("--data", help="YAML file with a `data` list replacing the run's data")
    p.add_argument("--precision", default="double", choices=["double", "float"])
    p.add_argument("--fast-math", action="store_true", help="compile with -O2 -ffast-math (default: -O2)")

    p = sub.add_parser("evaluate", help="score parameters without tuning (default: a run's best)")
    p.add_argument("target", help="a run directory or a config file")
    p.add_argument("--params", help="YAML file with parameters (a best.yaml works)")
    p.add_argument("--data", help="YAML file with a `data` list (or mapping) replacing the config's data")
    p.add_argument("--json", action="store_true", help="print {fitness, recordings: {...}} as JSON")

    p = sub.add_parser("cv", help="cross-validate a config: tune on the other folds, score the held-out fold")
    p.add_argument("config", help="a config file, or a finished run directory (its tables are written into it)")
    p.add_argument("--k", type=int, default=None, help="number of folds for k-fold (default: the objective's "
                   "groups, e.g. BROAD's trial groups, else 5)")
    p.add_argument("--dir", default=None, help="output directory (default: <output>/cv/<name>-<stamp>)")
    p.add_argument("--no-full", action="store_true", help="skip the tuning on all data (no gap)")
    p.add_argument("--budget-fraction", type=_fraction, default=None,
                   help="each tuning's budget relative to the config's, in (0, 1] (default: the config's "
                        "validation.budget_fraction, else 1)")
    p.add_argument("-q", "--quiet", action="store_true")
    p = sub.add_parser("sweep", help="run many jobs (configs x overrides x seeds) and write one report")
    p.add_argument("sweep", help="sweep YAML file")
    p.add_argument("--dir", help="sweep directory (default: runs/sweeps/<name>)")
    p.add_argument("--jobs", type=int, help="concurrent jobs (default: from the sweep file, else 1)")
    p.add_argument("-q", "--quiet", action="store_true")
    p.add_argument("--no-report", action="store_true", help="no reports, the jobs' nor the sweep's (results.csv and "
                                                            "summary.csv are written; `tuner report DIR` later)")

    p = sub.add_parser("report", help="(re)write the report of a sweep directory or a run directory, or the "
                                      "dashboard (index.html) of a folder of runs")
    p.add_argument("path")
    p = sub.add_parser("dashboard", help="write DIR/index.html: every run and sweep under DIR, sortable, filterable, "
                                         "compared side by side")
    p.add_argument("path", nargs="?", default="runs", help="folder of runs (default: runs)")

    p = sub.add_parser("init", help="write a commented starter job for a filter or controller")
    p.add_argument("name", help="a filter or controller `tuner list` prints, e.g. madgwick, pid")
    p.add_argument("-o", "--output", help="file to write (default: NAME.yaml); an existing file is never overwritten")

    p = sub.add_parser("demo", help="run a job shipped with the package (default: the demo, EKF vs FAEKF)")
    p.add_argument("job", nargs="?", default="demo", help="a packaged job, e.g. thesis_kf1d (see --list)")
    p.add_argument("--list", action="store_true", help="list the packaged jobs and where they are")
    p.add_argument("-q", "--quiet", action="store_true")
    return ap


def _cmd_run(a) -> int:
    from tuner.config import load_config
    from tuner.run import run
    from tuner.sweep import is_sweep_file

    if is_sweep_file(a.config):  # a sweep file runs as a sweep (e.g. the demo compares filters)
        if a.overrides or a.seed is not None or a.n_jobs or a.run_dir:
            raise UsageError(f"{a.config}: is a sweep file; --set/--seed/--n-jobs/--run-dir apply to job files")
        return _cmd_sweep(argparse.Namespace(sweep=a.config, dir=None, jobs=None, quiet=a.quiet,
                                             no_report=a.no_report))
    cfg = load_config(a.config, a.overrides, seed=a.seed, n_jobs=a.n_jobs)
    res = run(cfg, run_dir=a.run_dir, quiet=a.quiet, report=not a.no_report)
    return _print_result(res)


def _print_result(res) -> int:
    print(f"status: {res.status} ({res.stop_reason})")
    print(f"best fitness: {res.best_fitness:.6g} after {res.n_evals} evaluations")
    for k, v in res.best_params.items():
        print(f"  {k}: {v:.6g}" if isinstance(v, float) else f"  {k}: {v}")
    summary = res.extra.get("summary_table")
    if summary:
        print()
        print(summary)
    print(f"run directory: {res.run_dir}")
    if (res.run_dir / "report.md").exists():
        print(f"report: {res.run_dir / 'report.md'}")
    if res.status == "finished" and res.n_evals and not res.best_params:
        print(f"error: {res.run_dir}: every one of {res.n_evals} evaluations failed; "
              f"{_failure_summary(res.run_dir)}", file=sys.stderr)
        return 1
    return 0 if res.status == "finished" else 1


def _failure_summary(run_dir: Path) -> str:
    """The most frequent error text of a run's history (why every evaluation failed)."""
    import csv
    from collections import Counter

    try:
        with open(run_dir / "history.csv", newline="") as fh:
            errors = Counter(row.get("error", "") for row in csv.DictReader(fh))
    except OSError:
        return "see history.csv"
    errors.pop("", None)
    if not errors:
        return "see history.csv"
    (text, n), = errors.most_common(1)
    return f"most common reason ({n}x): {text}"


def _cmd_resume(a) -> int:
    from tuner.run import resume

    return _print_result(resume(a.run_dir, quiet=a.quiet, report=not a.no_report))


def _cmd_show(a) -> int:
    from tuner.runinfo import run_summary

    path = Path(a.path)
    if (path / "sweep.yaml").exists():
        from tuner.sweep import show_sweep

        print(show_sweep(path, as_json=a.json))
        return 0
    if not (path / "meta.json").exists() and not (path / "config.yaml").exists():
        raise UsageError(f"{path}: not a run or sweep directory (no meta.json / sweep.yaml)")
    from dataclasses import asdict

    from tuner.bounds import run_warnings
    from tuner.replay import verify_history
    from tuner.rundir import RunDir

    note = verify_history(RunDir(path))  # RunError naming an edited row
    s = run_summary(path)  # RunError naming the file if meta.json/best.yaml is corrupt
    warnings = run_warnings(path)
    if a.json:
        print(json.dumps({**s, "warnings": [asdict(w) for w in warnings]}, indent=1, default=str))
        return 0
    print(f"run:        {s['run']}")
    print(f"status:     {s['status']} ({s['stop_reason']})")
    print(f"optimizer:  {s['optimizer']}  seed {s['seed']}")
    print(f"evals:      {s['n_evals']} ({s['n_failed']} failed), {s['wall_s'] or 0:.1f} s")
    _show_scores(path, s["best_fitness"], s["evaluation"], s["params"])
    if s["evaluation"].get("summary_table"):
        print()
        print(s["evaluation"]["summary_table"])
    for w in warnings:
        print(f"warning: {w.message}")
    if note:
        print(f"note: {note}")
    return 0


def _show_scores(path: Path, fit: float | None, evaluation: dict, params: dict) -> None:
    """What was tuned; best, test and CV scores with the gap, each with the defaults'; searched and fixed values."""
    from tuner.runinfo import fmt, scores, tuned_system

    t = tuned_system(path)
    print(f"tuned:      {t['kind']} {t['name']}".rstrip())
    sc = scores(evaluation)
    dflt = sc.get("defaults_fitness")
    print(("best:       " + fmt(float(fit)) if fit is not None else "best:       -")
          + (f" (defaults {fmt(dflt)})" if dflt is not None else ""))
    if "test_fitness" in sc:
        d = sc.get("defaults_test_fitness")
        print(f"test:       {fmt(sc['test_fitness'])}" + (f" (defaults {fmt(d)})" if d is not None else ""))
    if "cv_fitness" in sc:
        d, gap = sc.get("defaults_cv_fitness"), sc.get("cv_gap")
        print(f"cv:         {fmt(sc['cv_fitness'])}" + (f" (defaults {fmt(d)})" if d is not None else "")
              + (f"; tuning score {fmt(sc['tuning_score'])}" if "tuning_score" in sc else "")
              + (f", gap {gap:+.3g}" + (" LARGE" if sc.get("cv_gap_large") else "") if gap is not None else ""))
    searched = [k for k in params if k in t["searched"]] or [k for k in params if k not in t["fixed"]]
    for title, items in (("searched:", [(k, params[k]) for k in searched]), ("fixed:", list(t["fixed"].items()))):
        if items:
            print(title)
        for k, v in items:
            print(f"  {k:24s} {fmt(v)}")
    for note in t.get("notes", []):  # e.g. the scoring-only truth start the deployment replaced
        print(f"note:       {note}")


def _cmd_compare(a) -> int:
    import pandas as pd

    from tuner.runinfo import run_summary, scores, tuned_system

    cols = {}
    for d in a.run_dirs:
        s = run_summary(Path(d))  # RunError naming the file if meta.json/best.yaml is missing or corrupt
        t = tuned_system(Path(d))
        col = {"tuned": f"{t['kind']} {t['name']}".strip(), "status": s["status"], "optimizer": s["optimizer"],
               "seed": s["seed"], "n_evals": s["n_evals"], "best_fitness": s["best_fitness"], **scores(s["evaluation"])}
        col.update({f"param.{k}": v for k, v in s["params"].items() if k not in t["fixed"]})
        col.update({f"fixed.{k}": v for k, v in t["fixed"].items()})
        col.update({f"metric.{k}": v for k, v in s["metrics"].items() if not isinstance(v, (dict, list))})
        cols[s["run"]] = col
    from tuner.render import fmt_num

    table = pd.DataFrame(cols).map(lambda v: "-" if v is None or (isinstance(v, float) and v != v) else fmt_num(v))
    print(table.to_string())
    return 0


def _cmd_list(a) -> int:
    what = a.what
    if what == "runs":
        from tuner.sweep import list_runs

        print(list_runs(Path(a.dir)))
        return 0
    if what in ("all", "optimizers"):
        from tuner.optimizers import OPTIMIZERS

        print("optimizers:")
        for name, cls in sorted(OPTIMIZERS.items()):
            doc = (cls.__doc__ or "").strip().splitlines()[0]
            print(f"  {name:10s} {doc}")
    from tuner.registry import REGISTRY

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


def _cmd_describe(a) -> int:
    from tuner.describe import UnknownName, describe, format_text

    try:
        found = describe(a.name)
    except UnknownName as exc:
        raise UsageError(str(exc)) from None
    if a.json:
        from tuner.export_formats import to_json

        print(to_json({"name": a.name, "found": found}))  # strict JSON, inf as "inf" (nonfinite_paths)
    else:
        print("\n\n".join(format_text(d) for d in found))
    return 0


def _cmd_export(a) -> int:
    from tuner.export import export

    run_dir = Path(a.run_dir)
    if not (run_dir / "best.yaml").exists():
        raise UsageError(f"{run_dir}: no best.yaml (not a run directory, or nothing evaluated yet)")
    if a.prefix is not None and a.format not in ("c", "c-filter"):
        raise UsageError(f"--prefix {a.prefix!r}: names C identifiers, only for --format c or c-filter "
                         f"(got --format {a.format})")
    if a.prefix is not None and (not a.prefix.isidentifier() or not a.prefix.isascii()):
        raise UsageError(f"--prefix {a.prefix!r}: a C identifier ([A-Za-z_][A-Za-z0-9_]*)")
    if a.format == "c-filter":
        from tuner.export import export_c_filter

        files = export_c_filter(run_dir, a.precision, a.prefix)
        Path(a.out).mkdir(parents=True, exist_ok=True)
        for name, text in files.items():
            (Path(a.out) / name).write_text(text)
            print(f"wrote {Path(a.out) / name}", file=sys.stderr)
        return 0
    text = export(run_dir, a.format, prefix=a.prefix)
    if a.output:
        Path(a.output).write_text(text)
        print(f"wrote {a.output}", file=sys.stderr)
    else:
        sys.stdout.write(text)
    return 0


def _cmd_verify_c(a) -> int:
    from tuner.export import verify_c

    try:
        out = verify_c(a.run_dir, a.data, a.precision, ("-O2", "-ffast-math") if a.fast_math else ("-O2",))
    except FileNotFoundError as exc:
        raise UsageError(str(exc)) from None
    py, c = out["python"], out["c"]
    print(f"{out['filter']} in C ({out['precision']}, {' '.join(out['flags'])}) vs the model: "
          f"fitness {py.fitness:.6g} / {c.fitness:.6g} (difference {c.fitness - py.fitness:.3g}); "
          f"{out['seconds']['python']:.2f} s / {out['seconds']['c']:.2f} s")
    for rec, m in py.recordings.items():
        vals = "  ".join(f"{k}={v:.6g}/{c.recordings[rec][k]:.6g} ({c.recordings[rec][k] - v:+.2g})"
                         for k, v in m.items() if isinstance(v, (int, float)) and k.endswith("deg"))
        print(f"  {rec}: max angle {out['max_angle_rad'][rec]:.3g} rad  {vals}")
    return 0 if not (py.failed or c.failed) else 1


def _cmd_evaluate(a) -> int:
    from tuner.rescore import evaluate_target

    out = evaluate_target(a.target, params_file=a.params, data_file=a.data)
    for w in out.get("warnings", []):
        print(f"warning: {w}", file=sys.stderr)
    if a.json:
        print(json.dumps(out, indent=1, default=float))
    else:
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


def _fraction(text: str) -> float:
    """A number in (0, 1] (argparse type)."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number in (0, 1], got {text!r}") from None
    if not 0 < value <= 1:
        raise argparse.ArgumentTypeError(f"expected a number in (0, 1], got {text!r}")
    return value


def _cmd_cv(a) -> int:
    from tuner.config import load_config
    from tuner.cv import cross_validate, write_cv

    progress = None if a.quiet else (lambda m: print(m, file=sys.stderr, flush=True))
    if Path(a.config).is_dir():  # a finished run: its best is the tuning result, the tables go into it
        from tuner.registry import say_imports
        from tuner.rundir import RunDir
        from tuner.validation import cv_run_dir

        say_imports(RunDir(a.config).config().get("objective") or {}, Path(a.config) / "config.yaml")
        v = cv_run_dir(a.config, k=a.k, progress=progress, budget_fraction=a.budget_fraction)
        print(f"CV mean {v['cv_score']:.4g} (defaults {v['defaults_cv_score']:.4g}), tuning score "
              f"{v['tuning_score']:.4g}, gap {v['gap']:+.3g}{' (large)' if v['gap_large'] else ''}\n{a.config}")
        return 0
    cfg = load_config(a.config)
    frac = cfg.validation.budget_fraction if a.budget_fraction is None else a.budget_fraction
    out = cross_validate(cfg, k=a.k, full=not a.no_full, progress=progress, budget_fraction=frac)
    stamp = time.strftime("%Y%m%d-%H%M%S", time.gmtime())
    d = write_cv(out, a.dir or Path(cfg.output) / "cv" / f"{cfg.name}-{stamp}", cfg.validation)
    s = out.summary()
    print(f"CV mean {s['cv_mean']:.4g} (defaults {s['defaults_mean']:.4g})"
          + (f", tuning score {s['tuning_score']:.4g}, gap {s['gap']:+.3g}" if "gap" in s else "") + f"\n{d}")
    return 0


def _cmd_sweep(a) -> int:
    from tuner.sweep import collect, run_sweep, summary_text

    res = run_sweep(a.sweep, sweep_dir=a.dir, jobs=a.jobs, quiet=a.quiet, report=not a.no_report)
    if res.get("interrupted"):
        print(f"sweep interrupted; run the same command again to continue: {res['dir']}", file=sys.stderr)
        return 1
    print(summary_text(collect(res["dir"]), res["dir"]))
    print(f"sweep directory: {res['dir']}")
    if res["report"] is not None:
        print(f"report: {res['report']}")
    return 0 if res["ok"] else 1


def _cmd_report(a) -> int:
    path = Path(a.path)
    if (path / "sweep.yaml").exists():
        from tuner.sweep import write_missing_job_reports, write_sweep_report

        write_missing_job_reports(path)  # jobs of a sweep run with --no-report
        print(write_sweep_report(path))
    elif (path / "meta.json").exists() or (path / "config.yaml").exists():
        from tuner.replay import verify_history
        from tuner.report import write_run_report
        from tuner.rundir import RunDir

        if (path / "meta.json").exists():
            note = verify_history(RunDir(path))  # RunError naming an edited row
            if note:
                print(f"note: {note}", file=sys.stderr)
        print(write_run_report(path))  # RunError naming the file if one is corrupt
    elif path.is_dir():
        return _cmd_dashboard(a)
    else:
        raise UsageError(f"{path}: not a run or sweep directory, nor a folder of runs")
    return 0


def _cmd_dashboard(a) -> int:
    from tuner.dashboard import collect_runs, write_dashboard

    path = Path(a.path)
    if not path.is_dir():
        raise UsageError(f"{path}: not a folder (expected a folder of run directories, e.g. runs)")
    if not collect_runs(path):
        raise UsageError(f"{path}: no run or sweep directory in it (nor up to 4 levels down)")
    print(write_dashboard(path))
    return 0


def _cmd_init(a) -> int:
    from tuner.starter import StarterError, write_starter

    try:
        out = write_starter(a.name, a.output)
    except StarterError as exc:
        raise UsageError(str(exc)) from None
    print(f"wrote {out}; run it with: tuner run {out}")
    return 0


def _cmd_demo(a) -> int:
    from tuner.starter import StarterError, packaged_config, packaged_configs

    if a.list:
        names = packaged_configs()
        print(f"packaged jobs ({packaged_config(names[0]).parent}):")
        print("  " + ", ".join(n.removesuffix(".yaml") for n in names))
        return 0
    try:
        path = packaged_config(a.job if a.job.endswith(".yaml") else f"{a.job}.yaml")
    except StarterError as exc:
        raise UsageError(str(exc)) from None
    return _cmd_run(argparse.Namespace(config=str(path), overrides=[], seed=None, n_jobs=None, run_dir=None,
                                       no_report=False, quiet=a.quiet))


COMMANDS = {"run": _cmd_run, "resume": _cmd_resume, "show": _cmd_show, "compare": _cmd_compare,
            "list": _cmd_list, "describe": _cmd_describe, "export": _cmd_export, "evaluate": _cmd_evaluate,
            "cv": _cmd_cv, "sweep": _cmd_sweep, "report": _cmd_report, "init": _cmd_init, "demo": _cmd_demo,
            "dashboard": _cmd_dashboard, "verify-c": _cmd_verify_c}


def main(argv: list[str] | None = None) -> int:
    from tuner.config import ConfigError
    from tuner.registry import RegistryError
    from tuner.rundir import RunError  # tuner.run re-exports it; importing that costs every command ~0.1 s
    from tuner.space import SpaceError

    ap = build_parser()
    a = ap.parse_args(argv)
    if not a.command:
        ap.print_help()
        return 2
    from tuner import signals

    old_handlers = signals.install()  # SIGTERM and SIGHUP stop every command as Ctrl-C does
    try:
        try:
            code = COMMANDS[a.command](a)
            sys.stdout.flush()
            return code
        except (ConfigError, RunError, SpaceError, UsageError, RegistryError) as exc:
            print(f"error: {exc}", file=sys.stderr)
            return 2
        except OSError as exc:  # read-only directory, full disk...: one line naming the path
            if isinstance(exc, BrokenPipeError):
                raise
            where = exc.filename or "?"
            print(f"error: {where}: {exc.strerror or exc} (results written before this point are kept; "
                  "`tuner resume` continues a run)", file=sys.stderr)
            return 2
        except KeyboardInterrupt:  # runs handle their own; `tuner cv CONFIG` or a report stops here
            print("interrupted", file=sys.stderr)
            return 1
    except BrokenPipeError:  # stdout closed early (`tuner list | head -1`): stop quietly
        _silence_stdout()
        return 0
    finally:
        signals.restore(old_handlers)


def _silence_stdout() -> None:
    """Point stdout at /dev/null so that the interpreter's final flush does not fail again."""
    import os

    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        os.close(devnull)
    except (OSError, ValueError):  # pragma: no cover
        pass


def _entry() -> Any:  # pragma: no cover
    sys.exit(main())


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
