"""Sweeps: many ordinary runs (variants x grid x seeds) under one directory, and one report.

A sweep file::

    sweep:
      name: filters-bench
      base: ekf_bench6dof.yaml          # a job file (relative to this file) or an inline job mapping
      variants:                         # named override sets (optional): the "methods" compared
        ekf:   {objective.filter: ekf}
        faekf: {objective.filter: faekf, base: faekf_bench6dof.yaml}   # a variant may change base
      grid:                             # cartesian product of further overrides (optional)
        optimizer.method: [pso, cmaes]
      seeds: [1, 2, 3]                  # one run per seed (optional; default: the base's seed)
      jobs: 1                           # runs at the same time; >1 runs each job serially
      output: runs/sweeps               # parent of the sweep directory (default)

Every job is a normal run directory ``<sweep dir>/jobs/<job id>``. Re-running the same command
skips finished jobs and resumes interrupted ones, so a killed sweep loses at most the generation
each running job was in. Results are a pure function of the inputs: the report's table is the
same to the last digit however often the sweep was interrupted.
"""

from __future__ import annotations

import copy
import datetime as _dt
import hashlib
import itertools
import json
import shlex
import sys
from pathlib import Path
from typing import Any

import yaml

from tuner import safe_yaml
from tuner.config import ConfigError, apply_overrides, config_from_dict, read_yaml
from tuner.records import load_json
from tuner.rundir import RunDir, atomic_write, mark_stopped
from tuner.safe_io import check_not_link, read_bytes, read_text, refuse_links, regular, write_atomic

__all__ = ["load_sweep", "run_sweep", "write_sweep_report", "show_sweep", "is_sweep_file", "ranked_by",
           "RANKED_BY", "DEFAULTS_OF"]

JOBS_FILE = "jobs.json"
#: a job's ``meta.json`` status once it has ended: run again, it is skipped ("failed": every evaluation failed)
ENDED = ("finished", "failed")


def _plain_name(s: str) -> bool:
    return bool(s) and "/" not in s and "\\" not in s and s not in (".", "..") and "\0" not in s


_SWEEP_KEYS = ("name", "description", "base", "variants", "grid", "seeds", "jobs", "output")


def is_sweep_file(path: str | Path) -> bool:
    try:
        raw = safe_yaml.load(Path(path).read_text())
    except (OSError, UnicodeDecodeError, yaml.YAMLError):  # the job loader reports it
        return False
    return isinstance(raw, dict) and "sweep" in raw


def _overrides(d: dict[str, Any]) -> list[str]:
    return [f"{k}={json.dumps(v)}" for k, v in d.items()]


def _slug(v: Any) -> str:
    s = str(v)
    return "".join(c if c.isalnum() or c in "-_." else "_" for c in s)[:40]


def load_sweep(path: str | Path, overrides: list[str] | None = None) -> dict[str, Any]:
    """Read and expand a sweep file into ``{"name", "jobs": [{id, method, seed, overrides, raw}], ...}``;
    ``overrides`` (``--set key.path=value``) apply to every job, after its variant and grid values."""
    path = Path(path)
    doc = read_yaml(path)
    if not isinstance(doc, dict) or "sweep" not in doc or not isinstance(doc["sweep"], dict):
        raise ConfigError(path, "sweep", "expected a mapping under the top-level key 'sweep'")
    extra = sorted(set(doc) - {"sweep"})
    if extra:
        raise ConfigError(path, extra[0], "unknown top-level key; a sweep file has only 'sweep'")
    sw = doc["sweep"]
    unknown = sorted(set(sw) - set(_SWEEP_KEYS))
    if unknown:
        raise ConfigError(path, f"sweep.{unknown[0]}", f"unknown key; allowed: {', '.join(_SWEEP_KEYS)}")
    base_dir = path.resolve().parent

    def load_base(base: Any, key: str) -> tuple[dict, Path]:
        if isinstance(base, dict):
            return copy.deepcopy(base), base_dir
        if not isinstance(base, str):
            raise ConfigError(path, key, f"expected a job file name or an inline job mapping, got {base!r}")
        p = (base_dir / base).resolve()
        if not p.exists():
            raise ConfigError(path, key, f"file not found: {p}")
        raw = read_yaml(p)
        if not isinstance(raw, dict):
            raise ConfigError(p, "", "expected a job mapping")
        return raw, p.parent

    if "base" not in sw:
        raise ConfigError(path, "sweep.base", "missing: a job file or an inline job mapping")
    variants = sw.get("variants") or {"": {}}
    if not isinstance(variants, dict):
        raise ConfigError(path, "sweep.variants", "expected a mapping name -> overrides")
    grid = sw.get("grid") or {}
    if not isinstance(grid, dict) or not all(isinstance(v, list) and v for v in grid.values()):
        raise ConfigError(path, "sweep.grid", "expected a mapping key.path -> non-empty list of values")
    seeds = sw.get("seeds")
    if seeds is not None and (not isinstance(seeds, list) or not all(isinstance(s, int) for s in seeds)):
        raise ConfigError(path, "sweep.seeds", f"expected a list of integers, got {seeds!r}")
    jobs_n = sw.get("jobs", 1)
    if not isinstance(jobs_n, int) or jobs_n < 1:
        raise ConfigError(path, "sweep.jobs", f"expected an integer >= 1, got {jobs_n!r}")
    name = str(sw.get("name", path.stem))
    if not name or "/" in name or "\\" in name or name in (".", "..") or name.startswith("."):
        raise ConfigError(path, "sweep.name", f"must be a plain directory name (no '/', '\\', '..' or leading "
                                              f"'.'), got {name!r}")

    jobs = []
    keys = list(grid)
    for vname, vover in variants.items():
        if vover is not None and not isinstance(vover, dict):
            raise ConfigError(path, f"sweep.variants.{vname}",
                              f"expected a mapping of overrides (key.path: value), got {type(vover).__name__}")
        if not isinstance(vname, str) or vname in (".", "..") or "/" in vname or "\\" in vname:
            raise ConfigError(path, f"sweep.variants.{vname}", "variant names are plain names (no '/', '\\', '..')")
        vover = dict(vover or {})
        base_raw, bdir = load_base(vover.pop("base", sw["base"]), f"sweep.variants.{vname}.base")
        for combo in itertools.product(*[grid[k] for k in keys]) if keys else [()]:
            for seed in seeds or [base_raw.get("seed", 0)]:
                over = {**vover, **dict(zip(keys, combo)), "seed": seed}
                raw = apply_overrides(base_raw, _overrides(over), path)
                raw = apply_overrides(raw, list(overrides or []), "--set")  # the command line's, over the file's
                raw["output"] = "."  # unused: the sweep names each run directory
                parts = ([_slug(vname)] if vname else []) + [f"{k.split('.')[-1]}-{_slug(v)}"
                                                             for k, v in zip(keys, combo)]
                method = "/".join(parts) or name
                job_id = "__".join(parts + [f"seed-{seed}"])
                try:
                    config_from_dict(raw, source=f"{path} [{job_id}]", base_dir=bdir)
                except ConfigError as exc:
                    raise ConfigError(path, f"job {job_id}", str(exc)) from None
                jobs.append({"id": job_id, "method": method, "variant": vname,
                             "grid": dict(zip(keys, combo)), "seed": seed, "raw": raw, "base_dir": str(bdir)})
    ids = [j["id"] for j in jobs]
    if len(set(ids)) != len(ids):
        raise ConfigError(path, "sweep", "two jobs have the same id (repeated seeds or grid values?)")
    return {"name": name, "description": sw.get("description", ""), "jobs": jobs, "parallel_jobs": jobs_n,
            "output": sw.get("output", "runs/sweeps"), "source": str(path), "doc": doc}


def _job_status(run_dir: Path) -> str:
    rd = RunDir(run_dir)
    return rd.meta().status if rd.is_run() else "new"


def _stamp(path: Path) -> str | None:
    """A job stamp's text, or None when absent or not whole (written by an older tuner and torn)."""
    try:
        text = read_text(path)
        load_json(text)
    except FileNotFoundError:
        return None
    except (ValueError, UnicodeDecodeError):
        return None
    return text


def sweep_jobs(n: int, n_jobs: int) -> tuple[int, str]:
    """Runs at the same time (``--jobs``/``sweep.jobs``), capped at the jobs and the CPUs; (n, note or '')."""
    import os

    if isinstance(n, bool) or not isinstance(n, int) or n < 1:
        raise ConfigError("--jobs", "", f"expected an integer >= 1, got {n!r}")
    cap = max(1, min(n_jobs, os.cpu_count() or 1))
    if n > cap:
        return cap, f"{n} jobs at a time capped at {cap} (the sweep's jobs and this machine's CPUs)"
    return n, ""


def _job_list(sw: dict[str, Any]) -> dict[str, Any]:
    """What show and report need of a sweep, stored in its directory (no config is rebuilt from it)."""
    return {"name": sw["name"], "description": sw.get("description", ""), "source": sw["source"],
            "jobs": [{k: j[k] for k in ("id", "method", "variant", "grid", "seed")} for j in sw["jobs"]]}


def _run_job(job: dict[str, Any], run_dir: str, serial: bool, quiet: bool, report: bool = True) -> dict[str, Any]:
    """Run, resume or skip one job (module-level so a process pool can call it)."""
    from tuner.run import resume, run

    run_dir = Path(run_dir)
    raw = copy.deepcopy(job["raw"])
    if serial:
        raw["parallel"] = {"backend": "serial"}
    stamp = run_dir.parent / f".{run_dir.name}.json"  # the job's resolved config, beside its run directory
    resolved = json.dumps({"raw": job["raw"], "base_dir": job["base_dir"]}, sort_keys=True, default=str)
    if _stamp(stamp) not in (None, resolved):
        raise ConfigError(job["id"], "sweep", f"{run_dir} was run with another configuration (a base config "
                          "or an override changed); delete the sweep directory or choose another --dir")
    status = _job_status(run_dir)
    label = job["id"]
    printer = None if quiet else (lambda m: print(f"[{label}] {m}", file=sys.stderr, flush=True))
    if status in ENDED:
        return {"id": job["id"], "status": status, "action": "skipped"}
    if status != "new" or regular(run_dir / "config.yaml"):  # killed or interrupted: resume holds the lock,
        res = resume(run_dir, progress=printer, quiet=quiet, report=report)  # replays the history, goes on
        return {"id": job["id"], "status": res.status, "action": "resumed"}
    cfg = config_from_dict(raw, source=f"{job['id']}", base_dir=Path(job["base_dir"]))
    atomic_write(stamp, resolved)  # whole or absent: a torn stamp (disk full, kill) reads as "not started"
    res = run(cfg, run_dir=run_dir, progress=printer, quiet=quiet, report=report)
    return {"id": job["id"], "status": res.status, "action": "ran"}


def run_sweep(path: str | Path, sweep_dir: str | Path | None = None, jobs: int | None = None,
              quiet: bool = False, report: bool = True, overrides: list[str] | None = None) -> dict[str, Any]:
    """Run (or continue) every job of a sweep, then write its report. ``report=False`` writes no report, the
    jobs' nor the sweep's (``results.csv`` and ``summary.csv`` are written; ``tuner report SWEEP_DIR`` writes
    the reports later). ``overrides`` (``--set key.path=value``) apply to every job; a sweep directory run
    with other overrides is refused (its jobs' configurations differ)."""
    overrides = list(overrides or [])
    sw = load_sweep(path, overrides)
    out = Path(sweep_dir) if sweep_dir else Path(sw["output"]) / sw["name"]
    n_par, n_cap = sweep_jobs(sw["parallel_jobs"] if jobs is None else jobs, len(sw["jobs"]))
    check_not_link(out / "jobs")
    refuse_links(out)  # a sweep directory is data: nothing in it is followed (tuner.safe_io)
    out.mkdir(parents=True, exist_ok=True)
    (out / "jobs").mkdir(exist_ok=True)
    spec_text = yaml.safe_dump(sw["doc"], sort_keys=False)
    old = out / "sweep.yaml"
    if regular(old) and read_text(old) != spec_text:
        raise ConfigError(path, "sweep", f"{out} holds a different sweep; choose another --dir or delete it")
    atomic_write(old, spec_text)
    atomic_write(out / "command.txt", shlex.join(["tuner", "sweep", str(path)] + (["--dir", str(sweep_dir)]
                                                                                if sweep_dir else [])
                                                 + [a for o in overrides for a in ("--set", o)]) + "\n")
    atomic_write(out / JOBS_FILE, json.dumps(_job_list(sw), indent=1, default=str))  # show/report read this
    if n_cap and not quiet:
        print(f"note: {n_cap}", file=sys.stderr, flush=True)
    todo = [(j, str(out / "jobs" / j["id"])) for j in sw["jobs"]]
    if not quiet:
        done = sum(_job_status(Path(d)) in ENDED for _, d in todo)
        print(f"sweep {sw['name']}: {len(todo)} jobs ({done} already finished), {n_par} at a time -> {out}",
              file=sys.stderr, flush=True)
    if n_par > 1:
        from joblib import Parallel, delayed

        try:  # a stop signal here makes joblib kill its workers (their runs resume as after a kill -9)
            # absolute directories: joblib reuses its worker processes, whose working directory is the one
            # of the process that started them, maybe another than this sweep's (tuner.api after a chdir)
            results = Parallel(n_jobs=n_par, backend="loky")(
                delayed(_run_job)(j, str(Path(d).absolute()), True, True, report) for j, d in todo)
        except KeyboardInterrupt:
            mark_stopped([d for _, d in todo])  # the pool's workers were stopped with it
            return {"dir": out, "report": None, "ok": False, "results": [], "interrupted": True}
    else:
        from tuner.report import throttled

        results = []
        for j, d in todo:  # the report is rewritten between jobs (throttled): a live view of the sweep
            results.append(_run_job(j, d, False, quiet, report))
            if results[-1]["status"] == "interrupted":  # Ctrl-C, SIGTERM or SIGHUP: stop the sweep here
                return {"dir": out, "report": None, "ok": False, "results": results, "interrupted": True}
            if report and len(results) < len(todo):
                throttled(f"sweep:{out.resolve()}", lambda: write_sweep_report(out, live=True))
    if report:
        path_md = write_sweep_report(out)
    else:
        write_sweep_tables(out)
        path_md = None
    return {"dir": out, "report": path_md, "ok": all(r["status"] == "finished" for r in results),
            "results": results}


# --- results ------------------------------------------------------------------------------------
def _flat(prefix: str, d: dict[str, Any]) -> dict[str, Any]:
    out = {}
    for k, v in (d or {}).items():
        if isinstance(v, (int, float)) and not isinstance(v, bool):
            out[f"{prefix}{k}"] = v
    return out


def collect(sweep_dir: Path) -> Any:
    """One row per job: ids (``method``: the variant and the grid values; ``variant``: its variant alone), seed,
    status, the numeric grid values (``grid.<key>``), best fitness, train/test scores, parameters, metrics."""
    import pandas as pd

    sweep_dir = Path(sweep_dir)
    sw = load_sweep_from_dir(sweep_dir)
    rows = []
    for job in sw["jobs"]:
        d = sweep_dir / "jobs" / job["id"]
        row: dict[str, Any] = {"job": job["id"], "method": job["method"], "variant": job.get("variant") or "",
                               "seed": job["seed"], "status": _job_status(d), **_flat("grid.", job.get("grid") or {})}
        rd = RunDir(d)
        if row["status"] in ENDED and not rd.has_best():  # nothing to rank: say why
            row["status"] = "all failed"
            row["n_failed"] = rd.meta().n_failed
        if rd.has_best():
            best = rd.best()
            meta = rd.meta()
            row["best_fitness"] = best.fitness
            ev = best.evaluation
            if ev.get("train_fitness") is not None:
                row["train_fitness"] = ev["train_fitness"]
            if ev.get("test_fitness") is not None:
                row["test_fitness"] = ev["test_fitness"]
            if ev.get("cv_fitness") is not None:  # validation: cv (tuner.validation): CV score and its gap
                row["cv_fitness"] = ev["cv_fitness"]
                row["cv_gap"] = ev.get("cv_gap")
                row["cv_gap_large"] = "LARGE" if ev.get("cv_gap_large") else ""
            for key in DEFAULTS_OF.values():  # the defaults scored as each ranked score (tuner.validation)
                if ev.get(key) is not None:
                    row[key] = ev[key]
            for split in ("train", "test"):
                recs = ev.get(split) or {}
                if recs:
                    keys = sorted({k for m in recs.values() for k in m})
                    for k in keys:
                        vals = [m[k] for m in recs.values() if isinstance(m.get(k), (int, float))]
                        if vals:
                            row[f"{split}.{k}"] = sum(vals) / len(vals)
            row["n_evals"] = meta.n_evals
            row["wall_s"] = round(meta.timing.wall_s, 1)
            row.update(_flat("param.", best.params))
        rows.append(row)
    return pd.DataFrame(rows)


def load_sweep_from_dir(sweep_dir: Path) -> dict[str, Any]:
    """The jobs of a sweep directory from its own ``jobs.json`` (whatever the working directory; no config
    is rebuilt, nothing imported); a sweep directory of an older tuner is re-expanded from its sweep file."""
    sweep_dir = Path(sweep_dir)
    refuse_links(sweep_dir)
    if regular(sweep_dir / JOBS_FILE):
        try:
            doc = load_json(read_text(sweep_dir / JOBS_FILE))
            if not isinstance(doc, dict) or not isinstance(doc.get("jobs"), list) or \
                    not all(isinstance(j, dict) and isinstance(j.get("id"), str) and _plain_name(j["id"])
                            for j in doc["jobs"]):
                raise ValueError("expected {name, jobs: [{id, method, seed, ...}]} with plain job names")
        except (ValueError, UnicodeDecodeError) as exc:
            raise ConfigError(sweep_dir / JOBS_FILE, "", f"unreadable: {exc}") from None
        return {"description": "", **doc, "name": str(doc.get("name", sweep_dir.name))}
    try:
        cmd = shlex.split(read_text(sweep_dir / "command.txt")) if regular(sweep_dir / "command.txt") else []
    except ValueError:  # not a command line
        cmd = []
    src = Path(cmd[2]) if len(cmd) > 2 else sweep_dir / "sweep.yaml"
    if not src.exists():
        src = sweep_dir / "sweep.yaml"
    return load_sweep(src)


#: the scores a sweep ranks by, in order of preference: (column, what it is)
RANKED_BY = (("cv_fitness", "CV score (validation ran in every job)"),
             ("test_fitness", "test score (held-out recordings of every job)"),
             ("best_fitness", "train score (the tuning fitness; no validation or test data in every job)"))
#: ranked column -> the column of the defaults scored the same way
DEFAULTS_OF = {"cv_fitness": "defaults_cv_fitness", "test_fitness": "defaults_test_fitness",
               "best_fitness": "defaults_fitness"}


def ranked_by(df: Any) -> tuple[str, str]:
    """``(column, description)`` of the score a sweep ranks by: CV when every finished job has a CV score,
    else test when every one has a test score, else the train (tuning) score."""
    done = df[df["status"] == "finished"] if "status" in df else df
    for col, what in RANKED_BY:
        if col in done and len(done) and done[col].notna().all():
            return col, what
    return RANKED_BY[-1]


def summarize(df: Any) -> Any:
    """Mean, median, std, min and max (the spread) over seeds for each method and numeric metric, plus each
    method's defaults row (its defaults scored as the ranked score); ranked by the median of :func:`ranked_by`'s
    score.

    Columns ``("kind", "")`` (``tuned`` or ``defaults``) and ``("ranked_by", "")`` say what each row is and
    which score ranks; a defaults row is named ``<method> (defaults)`` and fills the ranked score only.
    """
    import pandas as pd

    if df.empty or "best_fitness" not in df:
        return pd.DataFrame()
    key_col, what = ranked_by(df)
    metrics = [c for c in ("cv_fitness", "best_fitness", "train_fitness", "test_fitness") if c in df] + \
        sorted(c for c in df.columns if c.startswith(("train.", "test.")))
    g = df[df["status"] == "finished"].groupby("method")
    parts = {}
    for m in metrics:
        agg = g[m].agg(["mean", "median", "std", "min", "max"])
        for stat in agg.columns:
            parts[(m, stat)] = agg[stat]
    out = pd.DataFrame(parts)
    out.insert(0, ("runs", "n"), g.size())
    out.insert(0, ("kind", ""), "tuned")
    dcol = DEFAULTS_OF[key_col]
    if dcol in df:
        d = g[dcol].agg(["mean", "median", "std", "min", "max"]).dropna(how="all")
        rows = pd.DataFrame({(key_col, stat): d[stat] for stat in d.columns})
        rows.insert(0, ("runs", "n"), g.size().loc[d.index])
        rows.insert(0, ("kind", ""), "defaults")
        rows.index = [f"{m} (defaults)" for m in d.index]
        out = pd.concat([out, rows])
    out = out.sort_values([(key_col, "median"), ("kind", "")], ascending=[True, False], na_position="last")
    out.insert(0, ("ranked_by", ""), key_col)
    out.insert(0, ("rank", ""), range(1, len(out) + 1))
    out.attrs["ranked_by"] = (key_col, what)
    return out


def _hash(path: Path) -> str:
    return hashlib.sha256(read_bytes(path)).hexdigest()[:16]


def write_sweep_tables(sweep_dir: str | Path) -> tuple[Any, Any, Any]:
    """The sweep's records, written with or without its report: ``results.csv`` (one row per job) and
    ``summary.csv`` (statistics over seeds, flat columns). Returns the jobs' frame, the summary and its flat
    form."""
    sweep_dir = Path(sweep_dir)
    df = collect(sweep_dir)
    write_atomic(sweep_dir / "results.csv", df.to_csv(index=False, float_format="%.17g"), fsync=False)
    summ = summarize(df)
    flat = summ.copy()
    flat.columns = [f"{a}.{b}" if b else a for a, b in flat.columns]
    write_atomic(sweep_dir / "summary.csv", flat.to_csv(float_format="%.17g"), fsync=False)
    return df, summ, flat


def write_missing_job_reports(sweep_dir: str | Path) -> int:
    """The report of every job run without one (``tuner sweep --no-report``); returns how many were written."""
    from tuner.report import write_run_report

    n = 0
    for job in load_sweep_from_dir(Path(sweep_dir))["jobs"]:
        rd = RunDir(Path(sweep_dir) / "jobs" / job["id"])
        if rd.is_run() and not regular(rd.file("report.md")):
            write_run_report(rd.path)
            n += 1
    return n


def write_sweep_report(sweep_dir: str | Path, live: bool = False) -> Path:
    """``report.md``, ``report.html`` (figures embedded), ``results.csv``, ``summary.csv`` and figures.

    ``live``: the sweep is still going; the HTML page reloads itself until every job has finished.
    """
    from tuner import interactive
    from tuner.plots import SWEEP_PLOTS, draw, figures_md
    from tuner.plots.context import SweepContext
    from tuner.render import md_escape
    from tuner.report import LIVE_REFRESH_S, sweep_warnings_md, write_html

    sweep_dir = Path(sweep_dir)
    sw = load_sweep_from_dir(sweep_dir)
    df, summ, flat = write_sweep_tables(sweep_dir)
    check_not_link(sweep_dir / "figures")
    drawn = draw(SWEEP_PLOTS, SweepContext(sweep_dir, df, ranked_by(df) if len(df) else RANKED_BY[-1]),
                 sweep_dir / "figures")
    jobs_dir = sweep_dir / "jobs"
    versions = {}
    hashes = []
    for job in sw["jobs"]:
        d = jobs_dir / job["id"]
        rd = RunDir(d)
        if rd.is_run():
            meta = rd.meta()
            hashes.append((job["id"], meta.config_hash[:16] or _hash(d / "config.yaml"), job["seed"]))
            if not versions:
                versions = {**meta.versions, "git_commit": meta.git_commit}
    command = read_text(sweep_dir / "command.txt").strip() if regular(sweep_dir / "command.txt") else ""
    key_col, what = summ.attrs.get("ranked_by", ranked_by(df)) if len(df) else RANKED_BY[-1]
    fit_cols = tuple(dict.fromkeys((key_col, *(("train_fitness", "test_fitness") if "train_fitness.median"
                                                in flat.columns else ("best_fitness",)))))
    show_cols = [c for c in ["rank", "kind", "runs"] if c in flat.columns] + \
        [c for c in flat.columns if c.endswith((".median", ".min", ".max")) and c.split(".")[0] in fit_cols]
    ranking = flat[show_cols].reset_index().rename(columns={"index": "method"}) if len(flat) else flat
    if len(ranking):
        ranking = ranking[["rank", "method"] + [c for c in ranking.columns if c not in ("rank", "method")]]
    main_cols = [c for c in ["job", "method", "seed", "status", "best_fitness", "train_fitness", "test_fitness",
                             "cv_fitness", "cv_gap", "cv_gap_large", DEFAULTS_OF[key_col], "n_evals", "wall_s"]
                 if c in df.columns]
    running = live and not (len(df) and df["status"].isin(["finished", "all failed"]).all())
    md = [f"# Sweep {md_escape(sw['name'])}", "", md_escape(sw.get("description") or ""), "",
          f"{len(df)} jobs, {int((df['status'] == 'finished').sum()) if len(df) else 0} finished. "
          f"Written {_dt.datetime.now(_dt.UTC).strftime('%Y-%m-%d %H:%M UTC')}.", "",
          "## Ranking (over seeds)", "",
          f"Ranked by the median {what} (`{key_col}`); min and max are the spread over the seeds (the best and "
          "the worst seed). Each method's defaults row holds its defaults (the config's fixed values with the "
          "searched parameters at the objective's defaults) scored the same way.", "", _md(ranking), "",
          "## Every job", "", _md(df[main_cols]), "",
          *sweep_warnings_md(jobs_dir, [j["id"] for j in sw["jobs"]]),
          "Full tables: [results.csv](results.csv) (one row per job, all metrics and parameters), "
          "[summary.csv](summary.csv) (mean, median, std, min, max over seeds).", ""]
    test_cols = [c for c in df.columns if c.startswith("test.")]
    if test_cols:
        md += ["## Held-out recordings (mean over test recordings)", "",
               _md(df[["job"] + [c for c in df.columns if c.startswith("train.")] + test_cols]), ""]
    elif any(c.startswith("train.") for c in df.columns):  # e.g. closed loop: F, peaks, rise times
        md += ["## Scores of the best parameters (objective's evaluation)", "",
               _md(df[["job"] + [c for c in df.columns if c.startswith("train.")]]), ""]
    at_figures = len(md)
    md += ["## Figures", ""] + figures_md(drawn, sweep_dir)
    after_figures = len(md)
    per_run = [(j["id"], jobs_dir / j["id"] / "report.md") for j in sw["jobs"]]
    md += ["## Runs", ""] + [f"- [{i}](jobs/{i}/report.md)" for i, p in per_run if regular(p)] + [""]
    md += ["## Reproduce", "", "```", command or f"tuner sweep {sw['source']}", "```", "",
           "Versions: " + ", ".join(f"{k} {v}" for k, v in versions.items()), "",
           "| job | config sha256 (16) | seed |", "|---|---|---|"] + \
          [f"| {i} | `{h}` | {s} |" for i, h, s in hashes] + [""]
    text = "\n".join(md)
    atomic_write(sweep_dir / "report.md", text)
    scripts, data = (), None
    if interactive.available():  # sortable tables and the plots with a slot zoomable (tuner.interactive)
        data = interactive.page_data(drawn)
        text = "\n".join(md[:at_figures] + ["## Figures", ""] + figures_md(drawn, sweep_dir, interactive=True)
                         + md[after_figures:])
        interactive.install_assets(sweep_dir)
        scripts = interactive.SCRIPTS
    if running:
        text = f"> Live view: the sweep is still going; the page reloads every {LIVE_REFRESH_S:g} s.\n\n" + text
    write_html(sweep_dir / "report.html", text, sweep_dir, title=f"Sweep {sw['name']}",
               refresh_s=LIVE_REFRESH_S if running else None, scripts=scripts, data=data)
    return sweep_dir / "report.md"


def _md(df: Any) -> str:
    from tuner.report import md_table

    return md_table(df)


def show_sweep(sweep_dir: Path, as_json: bool = False) -> str:
    df = collect(Path(sweep_dir))
    if as_json:
        return df.to_json(orient="records", indent=1)
    cols = [c for c in ["job", "status", "best_fitness", "train_fitness", "test_fitness", "cv_fitness", "cv_gap",
                        "n_evals", "wall_s"] if c in df.columns]
    return "\n".join([df[cols].to_string(index=False), *ranking_lines(df)])


def ranking_lines(df: Any) -> list[str]:
    """The sweep's ranking for the terminal: which score ranks, then one line per method and defaults row."""
    summ = summarize(df)
    if not len(summ):
        return []
    key_col, what = summ.attrs["ranked_by"]
    return [f"ranking by the median {what}, with each method's defaults scored the same way:",
            *(f"  {int(r[('rank', '')])}. {name}: {key_col} {r[(key_col, 'median')]:.4g}"
              + (f" (seeds {r[(key_col, 'min')]:.4g} .. {r[(key_col, 'max')]:.4g}, {int(r[('runs', 'n')])} runs)"
                 if int(r[("runs", "n")]) > 1 else "")
              for name, r in summ.iterrows())]


def summary_text(df: Any, sweep_dir: Path) -> str:
    """The terminal table of a sweep: one row per job with train/test fitness and per-axis RMSE."""
    if df is None or len(df) == 0:
        return "(no jobs)"
    cols = [c for c in ["method", "seed", "status", "train_fitness", "test_fitness", "cv_fitness"] if c in df.columns]
    split = "test" if any(c.startswith("test.") for c in df.columns) else "train"
    for ax in ("roll", "pitch", "yaw"):
        c = f"{split}.{ax}_rmse_deg"
        if c in df.columns:
            cols.append(c)
    if "train_fitness" not in df.columns and "best_fitness" in df.columns:
        cols.insert(3, "best_fitness")
    out = df[cols].copy()
    out.columns = [c.replace(f"{split}.", f"{split} ").replace("_rmse_deg", " RMSE (deg)") for c in cols]
    lines = [out.to_string(index=False, float_format=lambda v: f"{v:.4g}"), *ranking_lines(df)]
    for _, r in df.iterrows():
        lines.append(f"  {r['job']}: {Path(sweep_dir) / 'jobs' / r['job']}")
    return "\n".join(lines)
