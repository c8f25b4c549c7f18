"""Run reports: ``report.md`` and a self-contained ``report.html`` (figures embedded).

Content: the objective's lead when it gives one (``headline_md`` among its ``finalize`` results: what a
reader needs first, e.g. a controller's gains and its requirements' pass/fail table), a summary card
(status, best fitness, budget and evaluations, failures, wall time, train /
test / CV scores and the generalisation gap), warnings (parameters at a search bound, failed
evaluations, see :mod:`tuner.bounds`; a large gap between CV and tuning score, see
:mod:`tuner.validation`), the cross-validation summary and the final selection when the run has them,
the best parameters within their bounds, a recording x metric table, the objective's other results,
and figures (convergence, fitness against each parameter, parallel coordinates of the best candidates,
then the objective's own figures from its ``finalize`` hook).

While a run is going, :func:`write_run_report` with ``live=True`` writes the same report with status
"running" and a page that reloads itself every ``refresh_s`` seconds; the final report does not
reload. Markdown becomes HTML in :mod:`tuner.render` (escaped names, sanitised links).
"""

from __future__ import annotations

import datetime as _dt
import json
import math
import re
import time
from pathlib import Path
from typing import Any

import pandas as pd

from tuner import interactive
from tuner.bounds import run_space, run_warnings
from tuner.dashboard import find_dashboard, write_dashboard
from tuner.deployment import DEFAULTS_MEANING
from tuner.objective import PENALTY
from tuner.plots import RUN_PLOTS, Drawn, draw, figures_md, objective_md, plot_files
from tuner.plots.context import RunContext, load_history
from tuner.render import fmt_num, md_escape, write_text_atomic
from tuner.render import md_table as _rows_table
from tuner.render import write_html as _write_html
from tuner.rundir import RunDir
from tuner.runinfo import run_summary
from tuner.spread import spread_md
from tuner.verdict import optimistic_note

__all__ = ["write_run_report", "load_history", "run_summary", "md_table", "pivot_metrics", "write_html",
           "write_live_report", "throttled", "sweep_warnings_md", "LIVE_REFRESH_S"]

#: seconds between reloads of a running run's report page
LIVE_REFRESH_S = 10.0
#: least seconds between two live reports of one run (and before the first): short runs write none
LIVE_MIN_INTERVAL_S = 5.0
#: the interval is also at least this many times the time the previous live report took (overhead <= 1/x)
LIVE_COST_FACTOR = 10.0
_live_last: dict[str, tuple[float, float]] = {}  # run directory -> (time of the last live report, its cost)


def write_html(path: Path, markdown: str, base_dir: Path, title: str | None = None,
               refresh_s: float | None = None, scripts: tuple[str, ...] = (), data: Any = None) -> Path:
    """Self-contained HTML page of a Markdown report (see :func:`tuner.render.write_html`)."""
    return _write_html(path, markdown, base_dir, title=title, refresh_s=refresh_s, scripts=scripts, data=data)


def md_table(df: pd.DataFrame, floatfmt: str = ".6g") -> str:
    """A pandas frame as a Markdown table, every cell escaped (``floatfmt``: ``.<digits>g``)."""
    if df is None or len(df) == 0:
        return "(no rows)"
    m = re.fullmatch(r"\.(\d+)g", floatfmt)
    digits = int(m.group(1)) if m else 6
    return _rows_table(df.to_numpy().tolist(), list(df.columns), digits)


# --- the recording x metric table ---------------------------------------------------------------
_REC_SLASH = re.compile(r"^rec/(?P<rec>[^/]+)/(?P<metric>.+)$")


def pivot_metrics(metrics: dict[str, Any]) -> pd.DataFrame:
    """Flattened metric keys as a table: rows = recordings, columns = metrics.

    Keys ``rec/<recording>/<metric>`` (a recording name holds no ``/``) and ``<recording>.<metric>``
    (what the filter objective writes for several recordings) are split; keys without a recording
    (one recording, or a closed-loop objective) form the row ``"-"``. Non-numeric values are left out.
    """
    cells: dict[str, dict[str, float]] = {}
    for k, v in metrics.items():
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            continue
        m = _REC_SLASH.match(k)
        if m:
            rec, metric = m.group("rec"), m.group("metric")
        elif "." in k:
            rec, metric = k.rsplit(".", 1)
        else:
            rec, metric = "-", k
        cells.setdefault(rec, {})[metric] = float(v)
    df = pd.DataFrame.from_dict(cells, orient="index")
    df.index.name = "recording"
    return df


def _split_tables(ev: dict[str, Any]) -> pd.DataFrame | None:
    """Rows (split, recording) x metrics from ``evaluation.train/test/cv`` (``{recording: {metric: v}}``)."""
    rows = []
    for split in ("train", "test", "cv"):
        recs = ev.get(split)
        if not isinstance(recs, dict):
            continue
        for name, m in recs.items():
            if isinstance(m, dict):
                rows.append({"split": split, "recording": name,
                             **{k: v for k, v in m.items() if isinstance(v, (int, float)) and not isinstance(v, bool)}})
    return pd.DataFrame(rows) if rows else None


def _frame_md(df: pd.DataFrame, digits: int = 4) -> str:
    """A frame as a Markdown table; missing cells (a metric a recording does not have) are empty."""
    cells = df.astype(object).where(df.notna(), None)
    return _rows_table(cells.to_numpy().tolist(), list(df.columns), digits)


# --- the report ----------------------------------------------------------------------------------
def _budget(cfg: dict[str, Any]) -> str:
    o = cfg.get("optimizer") or {}
    pop, gens = o.get("population"), o.get("generations")
    stages = (o.get("refine") or {}).get("stages", 1) or 1
    if isinstance(pop, int) and isinstance(gens, int):
        return f"{pop * gens * stages} ({pop} x {gens} generations" + (f" x {stages} stages)" if stages > 1 else ")")
    return f"{gens or '?'} generations of the default population" + (f" x {stages} stages" if stages > 1 else "")


def _wall(s: Any) -> str:
    if not isinstance(s, (int, float)):
        return "-"
    return f"{s:.1f} s" if s < 120 else f"{s:.0f} s ({_dt.timedelta(seconds=round(s))})"


def _card(s: dict[str, Any], cfg: dict[str, Any]) -> list[list[Any]]:
    ev = s["evaluation"]
    n, nf = s["n_evals"] or 0, s["n_failed"] or 0
    status = f"{s['status']}" + (f" ({s['stop_reason']})" if s["stop_reason"] else "")
    rows: list[list[Any]] = [["status", status], ["best fitness", s["best_fitness"] if s["best_fitness"] is not None
                                                  else "-"]]
    for key in _CARD_KEYS:
        if isinstance(ev.get(key), (int, float)) and not (key in _SAME_AS_BEST and _same(ev[key], s["best_fitness"])):
            v = ev[key] if not key.endswith(("fitness", "score")) else \
                _score_text(ev[key], ev.get("initial_error") if key == "initial_fitness" else None)
            rows.append([key.replace("_", " "), v])
        elif key == "initial_fitness" and ev.get("initial_error"):  # the defaults failed: why, never a penalty
            rows.append(["initial fitness", _score_text(math.inf, ev["initial_error"])])
    rows += [["evaluations / budget", f"{n} / {_budget(cfg)}"],
             ["failed evaluations", f"{nf} ({nf / n:.1%})" if n else str(nf)],
             ["wall time", _wall(s["wall_s"])],
             ["optimizer, seed", f"{s['optimizer']}, {s['seed']}"]]
    obj = cfg.get("objective") or {}
    what = ", ".join(f"{k} {obj[k]}" for k in ("kind", "filter", "controller", "function", "metric") if k in obj)
    if what:
        rows.append(["objective", what])
    if s["found"]:
        f = s["found"]
        rows.append(["best found at", "the objective's defaults (chosen on held-out data, not an evaluation of the "
                     "history)" if f.get("eval") == -1 else
                     f"stage {f.get('stage')}, generation {f.get('generation')}, evaluation {f.get('eval')}"])
    return rows


def _score_text(v: float, error: Any = None) -> Any:
    """A score as the card shows it: a failed evaluation's penalty (or inf) is "failed" with its reason."""
    if math.isfinite(v) and v < PENALTY:
        return v
    why = f": {str(error)[:160]}" if error else ""
    return f"failed{why}"


#: results the summary card shows (the "Other results" table leaves them out: no number printed twice)
_CARD_KEYS = ("train_fitness", "test_fitness", "tuning_score", "cv_fitness", "cv_gap", "initial_fitness",
              "improvement_pct", "initial_error")
#: results left out of the card when they equal the best fitness (the tuning data's score is the best fitness)
_SAME_AS_BEST = ("train_fitness", "best_fitness")
#: multi-line results that repeat a table of the report (the terminal summary of the per-recording scores, the
#: objective's lead shown first)
_REPEATS = ("summary_table", "tables_md", "headline_md")


def _same(a: Any, b: Any) -> bool:
    """Equal numbers (a result the report already shows under another name; NaN is never the same)."""
    return isinstance(b, (int, float)) and math.isclose(float(a), float(b), rel_tol=1e-12, abs_tol=0.0)


def _validation(run_dir: Path) -> dict[str, Any]:
    try:
        return RunDir(run_dir).validation() or {}
    except Exception:  # noqa: BLE001 - a damaged validation.json must not stop the report
        return {"cv": {"error": "validation.json unreadable"}}


def _gap_warning(val: dict[str, Any]) -> list[str]:
    cv = val.get("cv") or {}
    if not cv.get("gap_large"):
        return []
    return [f"- **generalisation gap**: CV score {fmt_num(cv['cv_score'], 4)} vs tuning score "
            f"{fmt_num(cv['tuning_score'], 4)} (gap {cv['gap']:+.3g}, large: {md_escape(cv.get('gap_rule', ''))}); "
            "the tuned parameters do not carry over to held-out data as well as the tuning score says."]


def _validation_md(val: dict[str, Any], cv_chose_defaults: bool = False) -> list[str]:
    """The ``validation.json`` results: tuning score, CV score, gap; the final selection's candidates."""
    md: list[str] = []
    cv = val.get("cv") or {}
    if cv.get("error"):
        md += ["## Generalisation", "", f"Cross-validation not run: {md_escape(cv['error'])}", ""]
    elif cv:
        gap = cv.get("gap")
        flag = " (large)" if cv.get("gap_large") else ""
        rows = [["tuning score (best parameters, every held-out fold)", cv.get("tuning_score")],
                ["CV score (tuned without the fold, scored on it)", cv.get("cv_score")],
                ["gap (CV - tuning)", (f"{gap:+.4g}{flag}" if isinstance(gap, (int, float)) else "-")],
                ["defaults, same folds", cv.get("defaults_cv_score")],
                ["folds", f"{cv.get('folds')} ({cv.get('kind')}), worst fold {fmt_num(cv.get('cv_fold_worst'), 4)}, "
                          f"std over folds {fmt_num(cv.get('cv_fold_std'), 3)}"],
                ["budget per fold", f"{cv.get('budget_fraction', 1.0):g} x the run's"]]
        md += ["## Generalisation", "", f"Cross-validation of this job ([cv.md](cv.md)); the gap is large when "
               f"{md_escape(cv.get('gap_rule', ''))}; {DEFAULTS_MEANING}.", "", _rows_table(rows, ["item", "value"], 4),
               ""]
        tr = cv.get("transfer") or []
        if tr:  # validation: {cv: {by: dataset}}: each dataset held out once
            md += ["### Transfer between datasets", "", "Each dataset held out: the defaults and the parameters tuned "
                   "on the other datasets, scored on its recordings (difference = tuned - defaults).", "",
                   _rows_table([[md_escape(r["dataset"]), r["n"], r["defaults"], r["tuned"],
                                 (f"{r['difference']:+.4g}" if isinstance(r["difference"], (int, float))
                                  and r["difference"] == r["difference"] else "-")] for r in tr],
                               ["dataset", "n", "defaults", "tuned on the others", "difference"], 4), ""]
    sel = val.get("selection") or {}
    if sel:
        rows = [[c["eval"], c["tuning_fitness"], c["holdout_fitness"],
                 "chosen" if c["eval"] == sel.get("chosen_eval") else
                 ("tuning best" if c["eval"] == sel.get("tuning_best_eval") else "")] for c in sel["candidates"]]
        d = sel.get("defaults")
        if d:  # include_defaults: the untuned values as one more candidate (tuner.validation)
            rows.append(["defaults" + (f" (outside bounds: {', '.join(d['outside_bounds'])})"
                                       if d.get("outside_bounds") else ""), d["tuning_fitness"],
                         d["holdout_fitness"], "chosen" if sel.get("defaults_chosen") else ""])
        md += ["## Final selection on a held-out fold", "",
               f"The {sel['top_k']} best distinct candidates of the tuning (which did not see fold "
               f"`{md_escape(sel['holdout'])}`, {sel.get('n_holdout')} recordings) rescored on that fold; the best "
               "there is best.yaml" + (" (not the tuning best)." if sel.get("changed") else " (the tuning best).")
               + (" The run's cross-validation then chose the defaults over it: best.yaml holds the defaults."
                  if cv_chose_defaults else ""), "",
               _rows_table(rows, ["evaluation", "tuning fitness", "held-out fitness", ""], 4), ""]
    return md


def _params_rows(params: dict[str, Any], space: Any) -> list[list[Any]]:
    rows = []
    for k, v in params.items():
        p = space[k] if space is not None and k in space else None
        if p is None or p.is_fixed:
            shown = v if not isinstance(v, (list, dict)) else json.dumps(v)
            rows.append([k, shown, "fixed", "", "", p.unit if p else ""])
            continue
        pos = p.to_unit(float(v)) if isinstance(v, (int, float)) and not isinstance(v, bool) else math.nan
        rows.append([k, v, f"[{fmt_num(p.low, 4)}, {fmt_num(p.high, 4)}]", p.scale, f"{pos:.1%}", p.unit])
    return rows


def write_run_report(run_dir: Path, meta: dict[str, Any] | None = None, live: bool = False,
                     refresh_s: float = LIVE_REFRESH_S) -> Path:
    """Write ``report.md``, ``report.html`` and the report figures of a run directory.

    Parameters
    ----------
    run_dir : path
        The run directory.
    meta : dict, optional
        The run's current ``meta.json`` content, when the caller holds a newer one than the file.
    live : bool
        A report of a running run: the HTML page reloads itself every ``refresh_s`` seconds while the
        status is ``running``. Objective figures are not redrawn (they come after the run).
    """
    run_dir = Path(run_dir)
    s = run_summary(run_dir, meta)
    cfg = RunDir(run_dir).config() if (run_dir / "config.yaml").exists() else {}
    space = run_space(run_dir)
    running = live and s["status"] == "running"
    if not live:
        _live_last.pop(str(run_dir.resolve()), None)
    now = _dt.datetime.now(_dt.UTC).strftime("%Y-%m-%d %H:%M:%S UTC")
    title = f"Run {s['run']}"
    md = [f"# {md_escape(title)}", ""]
    if running:
        md += [f"> Live view: this run is still going; the page reloads every {refresh_s:g} s. "
               f"Last written {now}.", ""]
    desc = cfg.get("description")
    if desc:
        md += [md_escape(desc), ""]
    lead = s["evaluation"].get("headline_md")
    if isinstance(lead, str) and lead.strip():  # the objective's lead (raw HTML stays off in the page)
        md += [lead.rstrip(), ""]
    md += ["## Summary", "", _rows_table(_card(s, cfg), ["item", "value"], 6), ""]
    md += [f"Note: {md_escape(n)}." for n in s["notes"]] + ([""] if s["notes"] else [])
    rep = RunDir(run_dir).repeats()
    if rep is not None:
        md += spread_md(rep)

    warnings = run_warnings(run_dir)
    val = _validation(run_dir)
    md += ["## Warnings", ""]
    optimistic = optimistic_note((cfg.get("validation") or {}).get("chosen_on"))
    md += [f"- **{w.kind}**: {md_escape(w.message)}" for w in warnings] + _gap_warning(val) \
        + ([f"- **optimistic CV**: {md_escape(optimistic)}."] if optimistic else []) \
        or ["None: no parameter within 2 % of a search bound, no failed evaluation."]
    md += [""]
    md += _validation_md(val, bool(s["evaluation"].get("cv_deploys_defaults")))
    if s["params"]:
        md += ["## Best parameters", "", "Position in bounds: 0 % = low bound, 100 % = high bound, measured in "
               "log10 for log-scaled parameters.", "",
               _rows_table(_params_rows(s["params"], space), ["parameter", "value", "bounds", "scale",
                                                              "position in bounds", "unit"], 6), ""]
    md += _results_md(s)
    at_figures = len(md)
    drawn, own = _figures(run_dir, s, space, live)
    md += ["## Figures", ""] + (figures_md(drawn, run_dir) + objective_md(own) if drawn
                                else ["(no evaluation yet)", ""])
    after_figures = len(md)
    files = [("history.csv", "every evaluation"), ("best.yaml", "best parameters and scores"),
             ("config.yaml", "the resolved config"), ("meta.json", "status, times, versions"),
             ("scores.csv", "scores per recording"), ("cv.md", "cross-validation tables"),
             ("validation.json", "cross-validation summary and final selection")]
    known = {n for n, _ in files} | {"report.md"}
    files += [(p.name, "the objective's tables") for p in sorted(run_dir.glob("*.md")) if p.name not in known]
    md += ["## Files", ""] + [f"- [{md_escape(n)}]({n}): {what}" for n, what in files if (run_dir / n).exists()]
    md += ["", f"Written {now}.", ""]
    text = "\n".join(md)
    path = run_dir / "report.md"
    write_text_atomic(path, text)
    fig_md, data = _interactive(run_dir, drawn, own, live)
    html_md = text if data is None else "\n".join(md[:at_figures] + fig_md + md[after_figures:])
    write_html(run_dir / "report.html", html_md, run_dir, title=title, refresh_s=refresh_s if running else None,
               scripts=interactive.SCRIPTS if data is not None else (), data=data)
    _refresh_dashboard(run_dir)
    return path


def _refresh_dashboard(run_dir: Path) -> None:
    """Rewrite the runs dashboard above ``run_dir`` (:mod:`tuner.dashboard`), if there is one.

    Live reports are throttled (:func:`write_live_report`) and their cost includes this rewrite, so a
    dashboard over many runs makes the live view of each run less frequent, not the run slower.
    """
    root = find_dashboard(run_dir)
    if root is not None:
        write_dashboard(root, LIVE_REFRESH_S)


def _interactive(run_dir: Path, drawn: list[Drawn], own: list[Path], live: bool) -> tuple[list[str], dict | None]:
    """The interactive figures section and page data (:mod:`tuner.interactive`), or ``([], None)``."""
    if not interactive.available() or not drawn:
        return [], None
    fig_md, data = interactive.run_figures(run_dir, drawn, own, live)
    interactive.install_assets(run_dir)
    return fig_md, data


def write_live_report(run_dir: Path, meta: dict[str, Any], final: bool = False, min_interval_s: float | None = None,
                      refresh_s: float = LIVE_REFRESH_S) -> Path | None:
    """The live view of a running run, called after every generation.

    Rewrites ``report.md``/``report.html`` (the page reloads every ``refresh_s`` s) when ``min_interval_s``
    (default :data:`LIVE_MIN_INTERVAL_S`) have passed since the previous live report, or since the first
    call, and at least :data:`LIVE_COST_FACTOR` times what the previous one took: short runs write none
    and a long run spends at most about a tenth of its time on its live view. ``final=True`` (an
    interrupted run) rewrites a report that does not reload, if a live one was written. Returns the
    report path, or ``None`` when nothing was written.
    """
    key = str(Path(run_dir).resolve())
    if final:
        if _live_last.pop(key, None) is None or not (Path(run_dir) / "report.html").exists():
            return None
        return write_run_report(run_dir, meta=meta, live=False)
    return throttled(key, lambda: write_run_report(run_dir, meta=meta, live=True, refresh_s=refresh_s),
                     min_interval_s)


def throttled(key: str, write: Any, min_interval_s: float | None = None) -> Any:
    """Call ``write()`` for the live view ``key`` if it is due (see :func:`write_live_report`).

    Returns what ``write()`` returned, or ``None`` when it was not due.
    """
    now = time.monotonic()
    interval = LIVE_MIN_INTERVAL_S if min_interval_s is None else min_interval_s
    last, cost = _live_last.setdefault(key, (now, 0.0))
    if now - last < max(interval, LIVE_COST_FACTOR * cost):
        return None
    out = write()
    done = time.monotonic()
    _live_last[key] = (done, done - now if interval > 0 else 0.0)
    return out


def sweep_warnings_md(jobs_dir: Path, job_ids: list[str]) -> list[str]:
    """The ``## Warnings`` section of a sweep report: bound and failure warnings of every job."""
    rows = [[job, w.kind, w.message] for job in job_ids if (Path(jobs_dir) / job / "meta.json").exists()
            for w in run_warnings(Path(jobs_dir) / job)]
    if not rows:
        return ["## Warnings", "", "None: no best parameter within 2 % of a search bound, no failed evaluation.", ""]
    return ["## Warnings", "", "Parameters within 2 % of a search bound (log10 range for log parameters) and "
            "failed evaluations, per job.", "", _rows_table(rows, ["job", "kind", "warning"]), ""]


def _results_md(s: dict[str, Any]) -> list[str]:
    ev = s["evaluation"]
    md: list[str] = []
    split_df = _split_tables(ev) if ev else None
    blocks = {k: v for k, v in ev.items() if isinstance(v, str) and "\n" in v and k not in _REPEATS}
    if split_df is not None or s["metrics"]:
        one_row = split_df is None and len(pivot_metrics(s["metrics"])) == 1
        md += ["## Metrics of the best candidate" if one_row else "## Scores per recording", ""]
        for k, v in blocks.items():
            md += [f"{md_escape(k.replace('_', ' '))}:", "", "```", v.replace("```", "'''"), "```", ""]
        if split_df is not None:
            md += ["Metrics of the best parameters on each recording (test recordings were not used for tuning).",
                   "", _frame_md(split_df), ""]
        else:
            piv = pivot_metrics(s["metrics"])
            words = ev.get("metric_words") if isinstance(ev.get("metric_words"), dict) else {}
            if len(piv) == 1:  # one recording (or none): metric per row reads better than one wide row
                md += ["Metrics of the best candidate.", "",
                       _rows_table([[words.get(k, k), k, v] if words else [k, v] for k, v in piv.iloc[0].items()],
                                   ["metric", "key", "value"] if words else ["metric", "value"], 4), ""]
            elif len(piv):
                md += ["Metrics of the best candidate on each recording.", "",
                       _frame_md(piv.rename(columns=lambda c: words.get(c, c)).reset_index()), ""]
    shown = {str(k).rsplit("/", 1)[-1].rsplit(".", 1)[-1]: v for k, v in s["metrics"].items()}
    scalars = [[k, v] for k, v in ev.items() if not isinstance(v, (dict, list)) and k not in _REPEATS
               and not (isinstance(v, str) and "\n" in v) and k not in _CARD_KEYS
               and not (k in _SAME_AS_BEST and _same(v, s["best_fitness"]))
               and not (k.startswith("best_") and isinstance(v, (int, float)) and _same(v, shown.get(k[5:])))]
    nested = {k: v for k, v in ev.items() if k not in ("train", "test", "cv") and isinstance(v, dict) and v
              and all(isinstance(x, dict) for x in v.values())}
    if scalars or nested:
        md += ["## Other results", ""]
        if scalars:
            words = ev.get("metric_words") if isinstance(ev.get("metric_words"), dict) else {}
            md += [_rows_table([[words.get(k, k), v] for k, v in scalars], ["result", "value"], 6), ""]
        for k, v in nested.items():
            rows = [[name] + [x if not isinstance(x, (dict, list)) else json.dumps(x) for x in d.values()]
                    for name, d in v.items()]
            head = ["name"] + list(next(iter(v.values())).keys())
            md += [f"{md_escape(k.replace('_', ' '))}:", "", _rows_table(rows, head, 4), ""]
    return md


def _figures(run_dir: Path, s: dict[str, Any], space: Any, live: bool) -> tuple[list[Drawn], list[Path]]:
    """The report's plots (:data:`tuner.plots.RUN_PLOTS`, each PNG written once) and the objective's own PNGs
    in ``figures/`` (not while the run is going: they come after it); nothing before the first evaluation."""
    src = RunDir(run_dir).chosen_repeat() or run_dir  # a repeated run draws its deployed repeat's history
    if not (src / "history.csv").exists():
        return [], []
    hist = load_history(src)
    if len(hist) == 0:
        return [], []
    figs = run_dir / "figures"
    drawn = draw(RUN_PLOTS, RunContext(run_dir, hist, space, dict(s["params"])), figs)
    mine = plot_files(RUN_PLOTS)
    own = [] if live and s["status"] == "running" else [p for p in sorted(figs.glob("*.png")) if p.name not in mine]
    return drawn, own
