"""How the engine draws a PNG: a :class:`matplotlib.figure.Figure` on its own Agg canvas, never ``pyplot``.

Nothing here touches matplotlib's process-wide state: no ``matplotlib.use`` (a notebook that calls
``tuner.tune()`` keeps its inline backend), no ``rcParams`` (the house sizes are passed to each artist: 10-point
text, 9-point legends), no figure registered with ``pyplot`` (nothing to close, nothing shown by a notebook
after the cell). Every figure is drawn for a page about 1100 px wide (``WIDTH_IN`` inches at ``DPI``), so the
HTML report shows it at its natural size. The report's plots are :mod:`tuner.plots`; a domain package's own
figures use :func:`new_figure` (or :func:`pyplot`, a stand-in with ``subplots``, ``figure`` and ``close``).
"""

from __future__ import annotations

from pathlib import Path
from types import SimpleNamespace
from typing import Any

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.ticker import FuncFormatter, NullLocator

from tuner.safe_io import check_not_link, write_atomic

__all__ = ["WIDTH_IN", "DPI", "TITLE_PT", "LEGEND_PT", "new_figure", "grid_figure", "save", "plain_log_labels",
           "log_y_if_wide", "method_color", "pyplot"]

WIDTH_IN = 10.5
DPI = 100
#: the house text sizes (points), passed to titles and legends (matplotlib's defaults: 12 and 10)
TITLE_PT = 10
LEGEND_PT = 9


def new_figure(height_in: float, width_in: float = WIDTH_IN, **kw: Any) -> Figure:
    """A figure of ``width_in`` x ``height_in`` inches on an Agg canvas of its own (``kw``: :class:`Figure`'s)."""
    fig = Figure(figsize=(width_in, height_in), **kw)
    FigureCanvasAgg(fig)
    return fig


def grid_figure(n: int, ncol_max: int = 3, row_in: float = 3.0) -> tuple[Figure, list[Any]]:
    """A page-wide figure of ``n`` axes, at most ``ncol_max`` per row, ``row_in`` inches a row, with fixed
    margins (constrained layout costs seconds per figure with a dozen log axes); unused cells hidden."""
    ncol = min(ncol_max, max(n, 1))
    nrow = int(np.ceil(n / ncol)) if n else 1
    h = row_in * nrow + 0.6
    fig = new_figure(h)
    axes = fig.subplots(nrow, ncol, squeeze=False).ravel()
    fig.subplots_adjust(left=0.08, right=0.9, bottom=0.62 / h, top=1 - 0.45 / h, wspace=0.28, hspace=0.75 / row_in)
    for ax in axes[n:]:
        ax.set_visible(False)
    return fig, list(axes[:n])


def save(fig: Figure, path: Path) -> Path:
    """Write ``fig`` through a temporary file and a rename, never through a symbolic link (:mod:`tuner.safe_io`)."""
    path = Path(path)
    check_not_link(path.parent)
    path.parent.mkdir(parents=True, exist_ok=True)
    write_atomic(path, lambda fh: fig.savefig(fh, dpi=DPI, format=path.suffix.lstrip(".") or "png"), fsync=False)
    return path


def plain_log_labels(axis: Any) -> None:
    """``1e-05`` instead of mathtext ``10^{-5}``, no minor ticks: both cost most of a figure's drawing time."""
    axis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:g}"))
    axis.set_minor_locator(NullLocator())  # minor ticks of log axes: hundreds of Tick objects, no information


def log_y_if_wide(ax: Any, values: Any) -> bool:
    """A log y axis when ``values`` are positive and span more than a factor 20; whether it was set."""
    v = np.asarray(values, float)
    v = v[np.isfinite(v)]
    if len(v) and v.min() > 0 and v.max() / v.min() > 20:
        ax.set_yscale("log")
        plain_log_labels(ax.yaxis)
        return True
    return False


def method_color(i: int) -> Any:
    """The colour of the ``i``-th method (sorted by name) in every sweep figure: matplotlib's ``tab10``."""
    from matplotlib import colormaps

    return colormaps["tab10"](i % 10)


def _subplots(nrows: int = 1, ncols: int = 1, *, figsize: tuple[float, float] = (6.4, 4.8), dpi: float | None = None,
              **kw: Any) -> tuple[Figure, Any]:
    fig = new_figure(figsize[1], figsize[0], dpi=dpi)
    return fig, fig.subplots(nrows, ncols, **kw)


def _figure(*, figsize: tuple[float, float] = (6.4, 4.8), dpi: float | None = None, **kw: Any) -> Figure:
    return new_figure(figsize[1], figsize[0], dpi=dpi, **kw)


def pyplot() -> SimpleNamespace:
    """A stand-in for the three ``matplotlib.pyplot`` calls figure code makes, with no global state:
    ``subplots(nrows, ncols, figsize=, dpi=, sharex=...)`` and ``figure(figsize=, dpi=)`` return figures of
    :func:`new_figure`, ``close(fig)`` does nothing (such a figure is never registered anywhere)."""
    return SimpleNamespace(subplots=_subplots, figure=_figure, close=lambda fig=None: None)
