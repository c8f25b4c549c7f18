"""Report figures of the closed-loop objective: fuzzy action surfaces (thesis Figs. 2.19-2.20), the
step responses before and after tuning as ``traces.json`` (the interactive report, :mod:`tuner.interactive`),
and the one way its figures are written (:func:`save_figure`)."""

from __future__ import annotations

import pathlib
from collections.abc import Mapping
from typing import Any

from tuner.safe_io import write_atomic

__all__ = ["plot_surfaces", "save_figure", "traces_doc"]

#: samples per plotted series
POINTS = 2000


def traces_doc(obj: Any, before: Mapping[str, Any], after: Mapping[str, Any]) -> dict[str, Any]:
    """Speed, yaw rate, IB angle and current of the initial and the tuned controller against the references.

    ``obj.traces(params)`` gives ``{panel title (unit): {"t", "y", "ref"}}``; a failed simulation (the
    robot fell) is shown for as long as it ran.
    """
    import math
    import re

    import numpy as np

    def col(a, step):
        v = np.round(np.asarray(a, float)[::step], 5)
        return [None if not np.isfinite(x) else float(x) for x in v]

    tr0, tr1 = obj.traces(dict(before)), obj.traces(dict(after))
    t = np.asarray(next(iter(tr1.values()))["t"], float)
    step = max(1, math.ceil(len(t) / POINTS))
    panels = []
    for key, v1 in tr1.items():
        m = re.match(r"^(.*?)\s*\(([^)]*)\)$", key)
        title, unit = (m.group(1), m.group(2)) if m else (key, "")
        series = []
        if v1.get("ref") is not None:
            series.append({"name": "reference", "y": col(v1["ref"], step), "dash": True, "color": "#222"})
        v0 = tr0.get(key)
        if v0 is not None and len(v0["y"]) == len(v1["y"]):
            series.append({"name": "initial", "y": col(v0["y"], step), "color": "#1f77b4"})
        series.append({"name": "tuned", "y": col(v1["y"], step), "color": "#d62728"})
        panels.append({"title": title, "unit": unit, "series": series})
    name = obj.profile if isinstance(obj.profile, str) else "profile"
    return {"title": "Step responses: initial vs tuned controller", "x_label": "time (s)", "select_label": "profile",
            "note": f"The closed loop of the {obj.controller} controller on the reference profile, with the initial "
                    "parameters and the tuned ones (thesis Figs. 2.16-2.18).",
            "replaces": ["response.png"],
            "items": [{"name": name, "label": f"profile {name}", "x": col(t, step), "panels": panels}]}


def save_figure(fig, path: str | pathlib.Path) -> pathlib.Path:
    """Lay out ``fig``, write it as a PNG at 110 dpi (creating the folder) and close it."""
    import matplotlib.pyplot as plt

    fig.tight_layout()
    path = pathlib.Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    write_atomic(path, lambda fh: fig.savefig(fh, format="png", dpi=110), fsync=False)
    plt.close(fig)
    return path


def plot_surfaces(
    ctrl: Any, before: Mapping[str, Any], after: Mapping[str, Any], fig_dir: str | pathlib.Path
) -> list[pathlib.Path]:
    """One PNG per fuzzy system of ``ctrl`` (``ctrl.surfaces(values)``): initial (left) vs tuned (right).

    Figs. 2.19 (FLC1 of the protective scheme: proportional tag over speed error and |I_A|) and 2.20
    (FLC2 over IB angle and rate errors). Returns the written paths ``fig_dir/surface_<name>.png``.
    """
    import numpy as np

    from tuner.figures import pyplot

    plt = pyplot()

    fig_dir = pathlib.Path(fig_dir)
    fig_dir.mkdir(parents=True, exist_ok=True)
    s0, s1 = ctrl.surfaces(dict(before)), ctrl.surfaces(dict(after))
    paths = []
    for name in s0:
        fig = plt.figure(figsize=(11, 4.6))
        for k, (label, s) in enumerate((("initial", s0[name]), ("tuned", s1[name]))):
            ax = fig.add_subplot(1, 2, k + 1, projection="3d")
            X, Y = np.meshgrid(s["x"], s["y"], indexing="ij")
            ax.plot_surface(X, Y, s["z"], cmap="viridis", linewidth=0, antialiased=True)
            ax.set_xlabel(s["x_label"])
            ax.set_ylabel(s["y_label"])
            ax.set_zlabel(s["z_label"])
            ax.set_title(f"{name.upper()} {label}")
        fig.tight_layout()
        path = fig_dir / f"surface_{name}.png"
        write_atomic(path, lambda fh, fig=fig: fig.savefig(fh, format="png", dpi=100), fsync=False)
        plt.close(fig)
        paths.append(path)
    return paths
