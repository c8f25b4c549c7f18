"""A dashboard over many runs: ``runs/index.html``, written by ``tuner dashboard`` or ``tuner report runs/``.

One row per run, per sweep and per sweep job found under the folder (run directories up to four
levels down): name, kind, objective, filter or controller, status, best fitness, CV score and gap,
evaluations, wall time and date, with a link to each report. With plotly installed
(:mod:`tuner.interactive`) the table sorts on a click, a filter box hides rows that do not contain its
text, and runs ticked in the first column are compared side by side (best parameters, metrics and
their convergence on one plot); without it the page is a static table. No server: the data is in the
page. While any listed run is running the page reloads itself every
``refresh_s`` s (10, as a running run's report); a run rewrites the dashboard of an ancestor folder (one holding
``.tuner-dashboard``) with its own live and final reports.
"""

from __future__ import annotations

import math
import os
from pathlib import Path
from typing import Any
from urllib.parse import quote

from tuner.verdict import defaults_verdict, transfer_line

__all__ = ["collect_runs", "write_dashboard", "find_dashboard", "MARKER", "MAX_DEPTH"]

#: file beside ``index.html`` that tells runs below the folder to refresh this dashboard
MARKER = ".tuner-dashboard"
#: how deep below the folder run and sweep directories are looked for (runs/sweeps/<name>/jobs/<id> = 4)
MAX_DEPTH = 4
#: seconds between reloads while a run is going (:data:`tuner.report.LIVE_REFRESH_S`, repeated: no import circle)
LIVE_REFRESH_S = 10.0


def _num(v: Any) -> float | None:
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(float(v)):
        return None
    return float(v)


def _dirs(d: Path) -> list[Path]:
    """The folders in ``d`` (no symbolic link, nor hidden ones), sorted; none when ``d`` cannot be listed."""
    try:
        return sorted(p for p in d.iterdir() if not p.name.startswith(".") and p.is_dir() and not p.is_symlink())
    except OSError:
        return []


def _walk(root: Path) -> list[tuple[str, Path]]:
    """(kind, path) of every sweep, sweep job and run directory under ``root``, in path order: run and sweep
    directories up to :data:`MAX_DEPTH` levels down, and every job of each sweep found (a sweep's jobs are
    ``jobs/<id>`` below it, however deep the sweep lies: a folder of several ``runs/`` folders included)."""
    found: list[tuple[str, Path]] = []

    def visit(d: Path, depth: int) -> None:
        for p in _dirs(d):
            if os.path.lexists(p / "sweep.yaml"):
                found.append(("sweep", p))
                found.extend(("job", j) for j in _dirs(p / "jobs") if os.path.lexists(j / "meta.json"))
                continue  # nothing below a sweep directory but its jobs
            if os.path.lexists(p / "meta.json"):
                found.append(("job" if p.parent.name == "jobs" else "run", p))
                continue  # nothing below a run directory is another run
            if depth < MAX_DEPTH:
                visit(p, depth + 1)

    visit(root, 1)
    return found


def _run_row(root: Path, d: Path, kind: str) -> dict[str, Any]:
    from tuner.plots.sweep_convergence import best_so_far
    from tuner.rundir import RunDir
    from tuner.runinfo import unreadable
    from tuner.safe_io import regular

    rel = d.relative_to(root).as_posix()
    row: dict[str, Any] = {"id": rel, "kind": kind, "name": rel if kind == "job" else d.name}
    try:
        rd = RunDir(d)
        meta = rd.meta().to_dict()
        best = rd.best().to_doc() if rd.has_best() else {}
        cfg = rd.config() if regular(d / "config.yaml") else {}
        rep = rd.repeats()
        conv = best_so_far(rd.chosen_repeat() or d)  # a repeated run: its deployed repeat's curve
    except Exception as exc:  # noqa: BLE001 - one damaged run must not hide the others
        return {**row, "status": f"unreadable: {unreadable(exc)}"}
    s = {"status": meta.get("status"), "n_evals": meta.get("n_evals"), "created": meta.get("created"),
         "wall_s": (meta.get("timing") or {}).get("wall_s"), "best_fitness": best.get("fitness"),
         "params": best.get("params") or {}, "metrics": best.get("metrics") or {}}
    obj = cfg.get("objective") or {}
    ev = best.get("evaluation") or {}
    val, transfer = {}, ""
    try:
        val = (rd.validation() or {}).get("cv") or {}
        transfer = transfer_line({"cv": val})
    except Exception:  # noqa: BLE001 - a damaged validation.json only loses the CV columns
        pass
    row.update({
        "objective": " ".join(str(obj[k]) for k in ("kind", "metric") if k in obj),
        "target": str(obj.get("filter") or obj.get("controller") or obj.get("function") or obj.get("callable") or ""),
        "status": (f"{s['status']}; tuned worse than defaults" if defaults_verdict(ev) else s["status"])
                  + (f"; {transfer}" if transfer else ""),
        "best": _num(s["best_fitness"]),
        "cv": _num(ev.get("cv_fitness", val.get("cv_score"))), "gap": _num(ev.get("cv_gap", val.get("gap"))),
        "n_evals": s["n_evals"], "wall_s": _num(s["wall_s"]), "date": (s["created"] or "")[:19],
        "params": {k: (v if isinstance(v, (int, float, str, bool)) else str(v)) for k, v in s["params"].items()},
        "metrics": {k: _num(v) for k, v in {**s["metrics"], **ev}.items() if _num(v) is not None},
        "conv": conv,
    })
    if rep is not None and rep.fitness is not None:  # the spread over the seeds beside the status
        from tuner.spread import fmt

        f = rep.fitness
        row["status"] = (f"{row['status']} · {rep.n} seeds, best {fmt(f.low)} .. {fmt(f.high)}"
                         + (" · large spread" if rep.warning else ""))
    if os.path.lexists(d / "report.html"):
        row["href"] = quote(f"{rel}/report.html", safe="/-_.~")
    return row


def _sweep_row(root: Path, d: Path, jobs: list[dict[str, Any]]) -> dict[str, Any]:
    rel = d.relative_to(root).as_posix()
    mine = [j for j in jobs if j["id"].startswith(rel + "/jobs/")]
    statuses = {j.get("status") for j in mine}
    best = [j["best"] for j in mine if j.get("best") is not None]
    cvs = [j["cv"] for j in mine if j.get("cv") is not None]
    row = {"id": rel, "kind": "sweep", "name": d.name,
           "objective": ", ".join(sorted({j.get("objective", "") for j in mine} - {""})),
           "target": ", ".join(sorted({j.get("target", "") for j in mine} - {""})),
           "status": ("running" if "running" in statuses else "finished" if statuses == {"finished"}
                      else ", ".join(sorted(str(s) for s in statuses)) or "no jobs yet"),
           "best": min(best) if best else None, "cv": min(cvs) if cvs else None, "gap": None,
           "n_evals": sum(int(j.get("n_evals") or 0) for j in mine),
           "wall_s": sum(j.get("wall_s") or 0.0 for j in mine) or None,
           "date": min((j.get("date") or "" for j in mine), default="")}
    if os.path.lexists(d / "report.html"):
        row["href"] = quote(f"{rel}/report.html", safe="/-_.~")
    return row


def collect_runs(root: str | Path) -> list[dict[str, Any]]:
    """The dashboard's rows (module docstring): runs and sweep jobs, then a summary row per sweep."""
    root = Path(root)
    found = _walk(root)
    rows = [_run_row(root, d, kind) for kind, d in found if kind != "sweep"]
    sweeps = [_sweep_row(root, d, rows) for kind, d in found if kind == "sweep"]
    return sweeps + rows


def _static_md(rows: list[dict[str, Any]]) -> list[str]:
    from tuner.render import md_escape, md_path, md_table

    head = ["name", "kind", "objective", "filter / controller", "status", "best", "CV score", "CV gap",
            "evaluations", "wall time (s)", "date"]
    keys = ["name", "kind", "objective", "target", "status", "best", "cv", "gap", "n_evals", "wall_s", "date"]
    table = md_table([[r.get(k) for k in keys] for r in rows], head, 4).splitlines()
    out = table[:2]
    for r, line in zip(rows, table[2:]):  # the name cell becomes a link to the report
        if r.get("href"):
            cell = md_escape(r["name"])
            line = line.replace(f"| {cell} |", f"| [{cell}]({md_path(r['id'] + '/report.html')}) |", 1)
        out.append(line)
    return out


def write_dashboard(root: str | Path, refresh_s: float = LIVE_REFRESH_S) -> Path:
    """Write ``<root>/index.html`` (and the marker that lets runs refresh it); returns its path.

    ``refresh_s``: seconds between reloads while a run is going (the run reports' live view uses the same).
    """
    from tuner import interactive
    from tuner.render import write_html, write_text_atomic

    root = Path(root)
    rows = collect_runs(root)
    running = any(r.get("status") == "running" for r in rows)
    import datetime as _dt

    now = _dt.datetime.now(_dt.UTC).strftime("%Y-%m-%d %H:%M:%S UTC")
    n_runs = sum(r["kind"] != "sweep" for r in rows)
    n_sweeps = len(rows) - n_runs
    counts = f"{n_runs} run{'' if n_runs == 1 else 's'} and {n_sweeps} sweep{'' if n_sweeps == 1 else 's'}"
    md = ["# Runs", "", f"{counts} under this folder. Written {now}." +
          (f" Some are running: the page reloads every {refresh_s:g} s." if running else ""), ""]
    scripts: tuple[str, ...] = ()
    data = None
    if interactive.available():
        md += ["Click a column header to sort, type in the box to filter, tick runs to compare them.", "",
               "{{plot:dashboard}}", ""]
        best = [r["best"] for r in rows if r.get("best") is not None and r["best"] > 0]
        data = {"dashboard": {"runs": rows, "log": bool(best and max(best) / min(best) > 20)}}
        interactive.install_assets(root)
        scripts = interactive.SCRIPTS
    else:
        md += _static_md(rows) + [""] if rows else ["(no run yet)", ""]
    path = root / "index.html"
    write_html(path, "\n".join(md), root, title=f"Runs in {root.resolve().name}",
               refresh_s=refresh_s if running else None, scripts=scripts, data=data)
    write_text_atomic(root / MARKER, "index.html here is rewritten by the runs below this folder\n")
    return path


def find_dashboard(run_dir: str | Path) -> Path | None:
    """The nearest ancestor of ``run_dir`` (up to :data:`MAX_DEPTH` levels up) holding a dashboard."""
    p = Path(run_dir).resolve()
    for anc in list(p.parents)[:MAX_DEPTH]:
        if (anc / MARKER).exists():
            return anc
    return None
