"""The report plots: one module per plot, its data computed once and drawn twice (STYLE convention 19).

A plot is a module (or any object) with

- ``NAME``: its slot in the interactive page (``{{plot:NAME}}``) and the function of ``tuner_report.js`` that
  draws it (``PLOTS[NAME]``); ``FILE``: its PNG in ``figures/``;
- ``data(ctx)``: everything both renderers draw, as plain data, from a :class:`~tuner.plots.context.RunContext`
  (run reports) or a :class:`~tuner.plots.context.SweepContext` (sweep reports); None when the plot does not
  apply (too few parameters or evaluations);
- ``title(data)``, ``caption(data)``: its heading and the sentence under it (plain text, escaped when written);
- ``figure(data)``: the PNG renderer, a :class:`matplotlib.figure.Figure` of :func:`tuner.figures.new_figure`;
- ``slot(data)``: the interactive renderer's JSON (what ``PLOTS[NAME]`` in ``tuner_report.js`` receives), or
  None: the interactive page then shows the PNG as the static one does.

:data:`RUN_PLOTS` and :data:`SWEEP_PLOTS` list them in report order; :func:`tuner.report.write_run_report` and
:func:`tuner.sweep.write_sweep_report` draw the list (:func:`draw`, :func:`figures_md`) and
:mod:`tuner.interactive` puts the slots of the same data into the page. Adding a plot is one module here, a line
in the list (or :func:`register`) and, if it is interactive, its drawing function in ``tuner_report.js``.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

from tuner.figures import save
from tuner.plots import (
    best_parameters,
    contour,
    convergence,
    errors_by_method,
    final_fitness,
    importance,
    parcoords,
    repeats,
    responses,
    slices,
    sweep_convergence,
    swept,
)
from tuner.render import md_escape, md_path

__all__ = ["RUN_PLOTS", "SWEEP_PLOTS", "Drawn", "register", "draw", "figures_md", "objective_md", "plot_files"]

#: a run report's plots, in the order the report shows them
RUN_PLOTS: list[Any] = [repeats, convergence, importance, slices, parcoords, contour]
#: a sweep report's plots
SWEEP_PLOTS: list[Any] = [sweep_convergence, final_fitness, swept, errors_by_method, responses, best_parameters]
_FACE = ("NAME", "FILE", "data", "title", "caption", "figure", "slot")


def register(plot: Any, plots: list[Any] | None = None) -> None:
    """Add ``plot`` at the end of ``plots`` (default :data:`RUN_PLOTS`); ``ValueError`` when it lacks a part of
    the face (module docstring) or its name or file is taken."""
    plots = RUN_PLOTS if plots is None else plots
    missing = [a for a in _FACE if not hasattr(plot, a)]
    if missing:
        raise ValueError(f"plot {getattr(plot, 'NAME', plot)!r}: missing {', '.join(missing)}")
    for other in plots:
        if other.NAME == plot.NAME or other.FILE == plot.FILE:
            raise ValueError(f"plot {plot.NAME!r} ({plot.FILE}): the name or file of {other.NAME!r} ({other.FILE})")
    plots.append(plot)


@dataclass(frozen=True)
class Drawn:
    """A plot drawn for one report: the plot, its data, heading, caption and PNG."""

    plot: Any
    data: Any
    title: str
    caption: str
    png: Path


def draw(plots: list[Any], ctx: Any, figs_dir: Path) -> list[Drawn]:
    """Compute each plot's data once and write its PNG into ``figs_dir``; the plots that apply, in order."""
    out = []
    for plot in plots:
        d = plot.data(ctx)
        if d is not None:
            out.append(Drawn(plot, d, plot.title(d), plot.caption(d), save(plot.figure(d), figs_dir / plot.FILE)))
    return out


def figures_md(drawn: list[Drawn], base: Path, interactive: bool = False) -> list[str]:
    """The Markdown of ``drawn`` (headings, captions, the PNGs relative to ``base``); ``interactive``: a
    ``{{plot:NAME}}`` slot instead of the PNG for every plot with a slot (:func:`tuner.interactive.page_data`)."""
    md: list[str] = []
    for d in drawn:
        md += [f"### {md_escape(d.title)}", ""] + ([md_escape(d.caption), ""] if d.caption else [])
        if interactive and d.plot.slot(d.data) is not None:
            md += [f"{{{{plot:{d.plot.NAME}}}}}", ""]
        else:
            md += [f"![{md_escape(d.title)}]({md_path(d.png.relative_to(base).as_posix())})", ""]
    return md


def objective_md(pngs: list[Path]) -> list[str]:
    """The objective's own figures (the PNGs its ``finalize`` hook wrote into ``figures/``), each under its name."""
    md: list[str] = []
    for png in pngs:
        name = png.stem.replace("_", " ")
        md += [f"### {md_escape(name)}", "", f"![{md_escape(name)}]({md_path('figures/' + png.name)})", ""]
    return md


def plot_files(plots: list[Any]) -> set[str]:
    """The PNG names ``plots`` write (every other PNG in ``figures/`` is the objective's own)."""
    return {p.FILE for p in plots}
