"""Report figures of the closed-loop objective: fuzzy action surfaces (thesis Figs. 2.19-2.20), and the
one way its figures are written (:func:`save_figure`)."""

from __future__ import annotations

import pathlib
from collections.abc import Mapping
from typing import Any

__all__ = ["plot_surfaces", "save_figure"]


def save_figure(fig, path: str | pathlib.Path) -> pathlib.Path:
    """Lay out ``fig``, write it as a PNG at 110 dpi (creating the folder) and close it."""
    import matplotlib.pyplot as plt

    fig.tight_layout()
    path = pathlib.Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
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
        fig.savefig(path, dpi=100)
        plt.close(fig)
        paths.append(path)
    return paths
