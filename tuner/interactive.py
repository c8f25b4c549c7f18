"""Interactive report pages: the data and the plot slots of ``report.html`` when plotly is installed.

Why plotly: it is maintained (a release every few weeks, MIT licence), draws every plot these pages
need (lines, scatter, contour, bars, linked subplots) as SVG without WebGL, gives zoom, hover and
legend toggles with no code of ours, and ships its whole JavaScript as one file
(``plotly/package_data/plotly.min.js``) that works from a local folder with no network. Bokeh and
Altair need a server or a CDN for the same; hand-written SVG would need our own zoom and hover.

Plotly stays optional (``pip install 'attitude-tuner[report]'``): without it every ``report.html`` is
the static page of :mod:`tuner.render` (PNG figures, no script). With it a page gets

- ``plotly.min.js`` once per folder and ``tuner_report.js`` (package data) beside it, checked by their SHA-256
  against the installed package's (:mod:`tuner.assets`: hard-linked to a matching copy in a folder above,
  else copied): the only scripts the page's policy admits (``script-src 'self'``);
- its data as one JSON block, and the plots drawn from it by ``tuner_report.js``: convergence,
  parameter importance (:mod:`tuner.importance`), fitness against each parameter, parallel coordinates
  of the best candidates, a contour of fitness over the two most important parameters, and the
  objective's time series (``traces.json``, below) with a selector; every table sorts on a click of
  its header.

``traces.json``, written into the run directory by an objective's ``finalize`` hook (the engine reads
it and knows nothing of what it shows)::

    {"title": "estimate vs truth", "x_label": "time (s)", "select_label": "recording",
     "note": "plain-words text shown above the plot",
     "replaces": ["errors_walk.png", ...],          # static figures the interactive one stands for
     "items": [{"name": "walk", "label": "test: walk (total RMSE 4.3 deg)", "x": [...],
                "panels": [{"title": "heading error", "unit": "deg",
                            "series": [{"name": "estimate", "y": [...], "dash": false}]}]}]}

The first item is the one shown first (the filter objective puts the worst recording first).
"""

from __future__ import annotations

import math
from importlib import resources
from importlib.util import find_spec
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from tuner.figures import convergence_table
from tuner.importance import importance_caption, quadratic_anova
from tuner.render import md_escape

__all__ = ["available", "install_assets", "SCRIPTS", "run_figures", "sweep_figures", "read_traces", "best_so_far",
           "MAX_POINTS"]

#: the scripts an interactive page loads, in order (file names beside the page)
SCRIPTS = ("plotly.min.js", "tuner_report.js")
#: at most this many evaluations go into a page's scatter plots (the best ones and an even spread of the rest)
MAX_POINTS = 4000


def available() -> bool:
    """True when plotly is installed (then reports are interactive)."""
    return find_spec("plotly") is not None


def _plotly_js() -> Path:
    spec = find_spec("plotly")
    if spec is None or not spec.submodule_search_locations:
        raise RuntimeError("plotly is not installed: interactive reports need pip install 'attitude-tuner[report]'")
    return Path(next(iter(spec.submodule_search_locations))) / "package_data" / "plotly.min.js"


def install_assets(folder: str | Path) -> None:
    """Put ``plotly.min.js`` and ``tuner_report.js`` into ``folder``: kept when their SHA-256 is the installed
    package's, else replaced (a hard link to a matching copy in a folder above, else a copy;
    :func:`tuner.assets.install`)."""
    from tuner.assets import install

    install(folder, "plotly.min.js", _plotly_js())
    with resources.as_file(resources.files("tuner").joinpath("static/tuner_report.js")) as js:
        install(folder, "tuner_report.js", js)


def read_traces(run_dir: Path) -> dict[str, Any] | None:
    """``traces.json`` of a run directory, or None (missing, unreadable or without items)."""
    from tuner.records import load_json
    from tuner.safe_io import read_text

    try:
        doc = load_json(read_text(Path(run_dir) / "traces.json"))
    except (OSError, ValueError):  # absent, unreadable, a link or a FIFO (tuner.safe_io): no time series
        return None
    if not isinstance(doc, dict) or not isinstance(doc.get("items"), list) or not doc["items"]:
        return None
    items = [it for it in doc["items"] if isinstance(it, dict) and isinstance(it.get("x"), list)
             and isinstance(it.get("panels"), list) and it["panels"]]
    return {**doc, "items": items} if items else None


def _log_fitness(f: np.ndarray) -> bool:
    f = f[np.isfinite(f)]
    return bool(len(f) and f.min() > 0 and f.max() / f.min() > 20)


def _thin(ok: pd.DataFrame) -> pd.DataFrame:
    """At most :data:`MAX_POINTS` rows: the best quarter of them, then an even spread of the others."""
    if len(ok) <= MAX_POINTS:
        return ok
    s = ok.sort_values("fitness", kind="stable")
    top = s.head(MAX_POINTS // 4)
    rest = s.iloc[MAX_POINTS // 4:]
    idx = np.linspace(0, len(rest) - 1, MAX_POINTS - len(top)).round().astype(int)
    return pd.concat([top, rest.iloc[np.unique(idx)]]).sort_values("eval")


def _phys(p: Any, u: np.ndarray) -> np.ndarray:
    """Unit-cube coordinates to physical values on a continuous scale (contour grids)."""
    if p.scale == "log":
        lo, hi = math.log10(p.low), math.log10(p.high)
        return 10 ** (lo + u * (hi - lo))
    return p.low + u * (p.high - p.low)


def _bands(k: int, n: int = 5) -> dict[str, list]:
    """Colour bands of ``k`` candidates sorted best first: ``band`` per candidate (n - 1 = the best fifth) and a
    label per band (``rank 1-6``; empty bands get ``""``)."""
    band = [n - 1 - (i * n) // k for i in range(k)]
    labels = []
    for b in range(n):
        ranks = [i + 1 for i in range(k) if band[i] == b]
        labels.append(f"rank {ranks[0]}-{ranks[-1]}" if len(ranks) > 1 else f"rank {ranks[0]}" if ranks else "")
    return {"band": band, "band_labels": labels}


def _contour(ok: pd.DataFrame, px: Any, py: Any, best: dict[str, Any], log: bool, n: int = 40) -> dict | None:
    """Fitness over two parameters, linearly interpolated between the evaluations (inside their hull)."""
    from scipy.interpolate import griddata
    from scipy.spatial import QhullError

    ux = np.array([px.to_unit(float(v)) for v in ok[px.name]])
    uy = np.array([py.to_unit(float(v)) for v in ok[py.name]])
    f = ok["fitness"].astype(float).to_numpy()
    z = np.log10(f) if log else f
    g = np.linspace(0.0, 1.0, n)
    GX, GY = np.meshgrid(g, g)
    try:
        Z = griddata(np.column_stack([ux, uy]), z, (GX, GY), method="linear")
    except (QhullError, ValueError):
        return None  # fewer than 3 points off one line: no surface
    if not np.isfinite(Z).any():
        return None
    return {"xp": {"name": px.name, "unit": px.unit, "scale": px.scale}, "yp": {"name": py.name, "unit": py.unit,
            "scale": py.scale}, "gx": _phys(px, g).tolist(), "gy": _phys(py, g).tolist(),
            "z": [[None if not np.isfinite(v) else round(float(v), 6) for v in row] for row in Z],
            "px": ok[px.name].astype(float).tolist(), "py": ok[py.name].astype(float).tolist(),
            "bx": float(best.get(px.name, math.nan)), "by": float(best.get(py.name, math.nan)), "log": log}


def run_figures(run_dir: Path, hist: pd.DataFrame, space: Any, best: dict[str, Any],
                objective_pngs: list[Path], live: bool) -> tuple[list[str], dict[str, Any]]:
    """The ``## Figures`` Markdown (with ``{{plot:NAME}}`` slots) and the page data of a run report.

    ``objective_pngs``: the objective's own static figures; those a ``traces.json`` replaces are left
    out, the others are embedded as images as in the static page.
    """
    from tuner.render import md_path

    data: dict[str, Any] = {}
    md = ["## Figures", "", "Interactive: drag to zoom, double-click to reset, click a legend entry to hide it. "
          "The same figures as PNG are in `figures/` (used by report.md).", ""]
    conv = convergence_table(hist)
    ok = hist[(hist["status"] == "ok") & np.isfinite(pd.to_numeric(hist["fitness"], errors="coerce"))].copy()
    ok["fitness"] = ok["fitness"].astype(float)
    f_all = ok["fitness"].to_numpy()
    log = _log_fitness(f_all)
    data["log_fitness"] = log
    data["convergence"] = {"n_evals": conv["n_evals"].tolist(), "best": conv["best"].tolist(),
                           "gen_median": conv["gen_median"].tolist()}
    md += ["### Convergence", "", "Best fitness so far and each generation's median against evaluations.", "",
           "{{plot:convergence}}", ""]
    params = [p for p in (space.free if space is not None else []) if p.name in hist.columns]
    if params and len(ok):
        thin = _thin(ok)
        best_f = float(f_all.min())
        data["params"] = [{"name": p.name, "unit": p.unit, "scale": p.scale, "low": p.low, "high": p.high}
                          for p in params]
        data["points"] = {"fitness": thin["fitness"].tolist(), "eval": thin["eval"].astype(int).tolist(),
                          "values": {p.name: thin[p.name].astype(float).tolist() for p in params}}
        data["best"] = {p.name: float(best[p.name]) for p in params if isinstance(best.get(p.name), (int, float))}
        data["best_fitness"] = best_f
        u = np.array([[p.to_unit(float(v)) for p, v in zip(params, row)]
                      for row in ok[[p.name for p in params]].to_numpy()])
        imp = quadratic_anova(u, f_all, [p.name for p in params])
        if imp is not None and len(params) > 1:
            order = imp.order()
            data["importance"] = {"names": order, "share": [float(imp.share[imp.names.index(n)]) for n in order]}
            md += ["### Parameter importance", "", md_escape(importance_caption(imp)), "", "{{plot:importance}}", ""]
        n_fail = int((hist["status"] != "ok").sum())
        md += ["### Fitness against each parameter", "", "Every successful evaluation (colour: evaluation number; "
               "dotted lines: the search bounds; star: the best)" + (f"; {n_fail} failed evaluations not shown."
                                                                     if n_fail else "."), "", "{{plot:slices}}", ""]
    if len(params) >= 2 and len(ok):  # one axis is no parallel coordinates (the slice above shows it)
        top = ok.sort_values("fitness", kind="stable").head(200)
        ut = np.array([[p.to_unit(float(v)) for p, v in zip(params, row)]
                       for row in top[[p.name for p in params]].to_numpy()])
        k = len(top)
        data["parcoords"] = {"names": [p.name for p in params], "u": np.round(ut, 5).tolist(),
                             "values": top[[p.name for p in params]].astype(float).to_numpy().tolist(),
                             "fitness": top["fitness"].tolist(), **_bands(k)}
        md += ["### Parallel coordinates of the best candidates", "", f"The {k} best candidates, one line each, "
               "over each parameter's position in its bounds (log10 for log parameters); darker = better.", "",
               "{{plot:parcoords}}", ""]
        names = imp.order()[:2] if imp is not None else [params[0].name, params[1].name]
        px, py = (next(p for p in params if p.name == n) for n in names)
        c = _contour(thin, px, py, data["best"], log)
        if c is not None:
            data["contour"] = c
            why = "the two most important parameters" if imp is not None else "the first two parameters"
            md += [f"### Fitness over {md_escape(px.name)} and {md_escape(py.name)}", "",
                   f"Contour of {'log10 ' if log else ''}fitness over {why}, interpolated linearly between "
                   "evaluations (blank outside them); the other parameters vary, so this is the landscape "
                   "the optimiser saw, not a slice at the best point.", "", "{{plot:contour}}", ""]
    replaced: set[str] = set()
    traces = None if live else read_traces(run_dir)
    if traces is not None:
        data["traces"] = traces
        replaced = {str(n) for n in traces.get("replaces", [])}
        md += [f"### {md_escape(traces.get('title', 'time series'))}", ""]
        if traces.get("note"):
            md += [md_escape(traces["note"]), ""]
        md += ["{{plot:traces}}", ""]
    for png in objective_pngs:
        if png.name not in replaced:
            name = png.stem.replace("_", " ")
            md += [f"### {md_escape(name)}", "", f"![{md_escape(name)}]({md_path('figures/' + png.name)})", ""]
    return md, data


def best_so_far(run_dir: Path, points: int = 200) -> dict[str, list[float]] | None:
    """A run's best fitness so far against evaluations (``x``, ``y``; at most ``points``), or None."""
    import io

    from tuner.safe_io import read_text

    try:  # through tuner.safe_io: a link or a FIFO named history.csv is no curve, never followed or waited on
        h = pd.read_csv(io.StringIO(read_text(Path(run_dir) / "history.csv")), usecols=["eval", "fitness", "status"])
    except (OSError, ValueError, pd.errors.ParserError, pd.errors.EmptyDataError):
        return None
    f = pd.to_numeric(h["fitness"], errors="coerce").where(h["status"] == "ok")
    best = f.cummin().to_numpy()
    x = (h["eval"].to_numpy() + 1).astype(float)
    keep = np.isfinite(best)
    if not keep.any():
        return None
    x, best = x[keep], best[keep]
    if len(x) > points:
        idx = np.unique(np.linspace(0, len(x) - 1, points).round().astype(int))
        x, best = x[idx], best[idx]
    return {"x": x.tolist(), "y": best.tolist()}


def sweep_figures(sweep_dir: Path, job_ids: list[str]) -> tuple[list[str], dict[str, Any]]:
    """The interactive section of a sweep report: every job's best-so-far fitness on one zoomable plot."""
    runs = []
    for job in job_ids:
        c = best_so_far(Path(sweep_dir) / "jobs" / job)
        if c is not None:
            runs.append({"name": job, **c})
    if not runs:
        return [], {}
    best = [min(r["y"]) for r in runs]
    md = ["## Convergence of every job (interactive)", "", "Best fitness so far of each job against its evaluations; "
          "click a job in the legend to hide it, double-click to show it alone.", "", "{{plot:convergence}}", ""]
    return md, {"convergence": {"runs": runs}, "log_fitness": bool(min(best) > 0 and max(r["y"][0] for r in runs)
                                                                   / min(best) > 20)}
