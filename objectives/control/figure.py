"""The one way the closed-loop figures are drawn and written: an explicit ``Figure`` on its own Agg canvas.

Nothing here touches pyplot, the process's matplotlib backend or its rcParams, so a notebook that
tunes a controller keeps its inline plots and its style (STYLE 19).
"""

from __future__ import annotations

import pathlib
from typing import Any

from tuner.safe_io import write_atomic

__all__ = ["new_figure", "save_figure"]


def new_figure(figsize: tuple[float, float]) -> Any:
    """A ``matplotlib.figure.Figure`` of ``figsize`` (inches) with an Agg canvas of its own."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=figsize)
    FigureCanvasAgg(fig)
    return fig


def save_figure(fig: Any, path: str | pathlib.Path, dpi: int = 110,
                rect: tuple[float, float, float, float] | None = None) -> pathlib.Path:
    """Lay out ``fig`` (its axes inside ``rect``, figure fractions (left, bottom, right, top), if given:
    room for a legend outside them) and write it as a PNG at ``dpi`` (creating the folder), through
    :func:`tuner.safe_io.write_atomic`: never through a link or into a hard-linked file of a run directory."""
    fig.tight_layout(rect=rect)
    path = pathlib.Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    write_atomic(path, lambda fh: fig.savefig(fh, format="png", dpi=dpi), fsync=False)
    return path
