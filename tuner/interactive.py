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
- its data as one JSON block, ``{NAME: slot}``, and the plots drawn from it by ``tuner_report.js``
  (``PLOTS[NAME](div, slot)``): the report's plots of :mod:`tuner.plots` (the same data their PNGs are
  drawn from: convergence, parameter importance, fitness against each parameter, parallel coordinates of
  the best candidates, a contour of fitness over the two most important parameters), and the objective's
  time series (``traces.json``, below) with a selector; every table sorts on a click of its header.

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

from importlib import resources
from importlib.util import find_spec
from pathlib import Path
from typing import Any

from tuner.plots import Drawn, figures_md, objective_md
from tuner.render import md_escape

__all__ = ["available", "install_assets", "SCRIPTS", "run_figures", "page_data", "read_traces"]

#: the scripts an interactive page loads, in order (file names beside the page)
SCRIPTS = ("plotly.min.js", "tuner_report.js")


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


def run_figures(run_dir: Path, drawn: list[Drawn], objective_pngs: list[Path],
                live: bool) -> tuple[list[str], dict[str, Any]]:
    """The ``## Figures`` Markdown (with ``{{plot:NAME}}`` slots) and the page data of a run report.

    ``drawn``: the report's plots (:func:`tuner.plots.draw`), each in its slot with the data its PNG was drawn
    from; ``objective_pngs``: the objective's own static figures, those a ``traces.json`` replaces left out.
    """
    md = ["## Figures", "", "Interactive: drag to zoom, double-click to reset, click a legend entry to hide it. "
          "The same figures as PNG are in `figures/` (used by report.md).", ""]
    md += figures_md(drawn, run_dir, interactive=True)
    data = page_data(drawn)
    replaced: set[str] = set()
    traces = None if live else read_traces(run_dir)
    if traces is not None:
        data["traces"] = traces
        replaced = {str(n) for n in traces.get("replaces", [])}
        md += [f"### {md_escape(traces.get('title', 'time series'))}", ""]
        if traces.get("note"):
            md += [md_escape(traces["note"]), ""]
        md += ["{{plot:traces}}", ""]
    return md + objective_md([p for p in objective_pngs if p.name not in replaced]), data


def page_data(drawn: list[Drawn]) -> dict[str, Any]:
    """``{NAME: slot}`` of every drawn plot with an interactive renderer (what ``tuner_report.js`` reads)."""
    return {d.plot.NAME: slot for d in drawn if (slot := d.plot.slot(d.data)) is not None}
