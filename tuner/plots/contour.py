"""Fitness over two parameters (the two most important, else the first two): a contour interpolated linearly
between the evaluations, blank outside their hull. The other parameters vary, so it is the landscape the
optimiser saw, not a slice at the best point."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from tuner.figures import TITLE_PT, new_figure, plain_log_labels
from tuner.plots.context import RunContext

NAME = "contour"
FILE = "contour.png"
#: grid points per axis
GRID = 40


def _phys(p: Any, u: np.ndarray) -> np.ndarray:
    """Unit-cube coordinates to physical values on a continuous scale."""
    if p.scale == "log":
        lo, hi = math.log10(p.low), math.log10(p.high)
        return 10 ** (lo + u * (hi - lo))
    return p.low + u * (p.high - p.low)


def data(ctx: RunContext) -> dict[str, Any] | None:
    """``xp``/``yp`` (name, unit, scale), the grid ``gx``, ``gy`` (physical values) and ``z`` (rows over ``gy``,
    None outside the evaluations' hull; log10 of the fitness when ``log``), the evaluations ``px``, ``py`` and
    the best ``bx``, ``by``; None with fewer than two searched parameters or three points off one line."""
    from scipy.interpolate import griddata
    from scipy.spatial import QhullError

    params, ok = ctx.params, ctx.thin
    if len(params) < 2 or not len(ok):
        return None
    imp = ctx.importance
    names = imp.order()[:2] if imp is not None else [params[0].name, params[1].name]
    px, py = (next(p for p in params if p.name == n) for n in names)
    ux = np.array([px.to_unit(float(v)) for v in ok[px.name]])
    uy = np.array([py.to_unit(float(v)) for v in ok[py.name]])
    f = ok["fitness"].to_numpy()
    z = np.log10(f) if ctx.log_fitness else f
    g = np.linspace(0.0, 1.0, GRID)
    try:
        Z = griddata(np.column_stack([ux, uy]), z, tuple(np.meshgrid(g, g)), method="linear")
    except (QhullError, ValueError):
        return None
    if not np.isfinite(Z).any():
        return None
    best = ctx.best
    return {"xp": {"name": px.name, "unit": px.unit, "scale": px.scale},
            "yp": {"name": py.name, "unit": py.unit, "scale": py.scale},
            "gx": _phys(px, g).tolist(), "gy": _phys(py, g).tolist(),
            "z": [[None if not np.isfinite(v) else round(float(v), 6) for v in row] for row in Z],
            "px": ok[px.name].astype(float).tolist(), "py": ok[py.name].astype(float).tolist(),
            "bx": float(best.get(px.name, math.nan)), "by": float(best.get(py.name, math.nan)),
            "log": ctx.log_fitness, "important": imp is not None}


def title(d: dict[str, Any]) -> str:
    return f"Fitness over {d['xp']['name']} and {d['yp']['name']}"


def caption(d: dict[str, Any]) -> str:
    why = "the two most important parameters" if d["important"] else "the first two parameters"
    return (f"Contour of {'log10 ' if d['log'] else ''}fitness over {why}, interpolated linearly between "
            "evaluations (blank outside them); the other parameters vary, so this is the landscape the optimiser "
            "saw, not a slice at the best point.")


def _label(p: dict[str, Any]) -> str:
    return f"{p['name']} ({p['unit']})" if p["unit"] else p["name"]


def figure(d: dict[str, Any]) -> Any:
    fig = new_figure(4.6)
    ax = fig.subplots()
    z = np.array([[np.nan if v is None else v for v in row] for row in d["z"]], float)
    cs = ax.contourf(d["gx"], d["gy"], np.ma.masked_invalid(z), levels=14, cmap="viridis_r")
    fig.colorbar(cs, ax=ax, label="log10 fitness" if d["log"] else "fitness", pad=0.01)
    ax.scatter(d["px"], d["py"], s=6, color="#222", lw=0)
    ax.scatter([d["bx"]], [d["by"]], marker="*", s=180, color="tab:red", edgecolor="k", zorder=5)
    for axis, p, set_scale in ((ax.xaxis, d["xp"], ax.set_xscale), (ax.yaxis, d["yp"], ax.set_yscale)):
        if p["scale"] == "log":
            set_scale("log")
            plain_log_labels(axis)
    ax.set_xlabel(_label(d["xp"]))
    ax.set_ylabel(_label(d["yp"]))
    ax.set_title(f"{'log10 ' if d['log'] else ''}fitness over {d['xp']['name']} and {d['yp']['name']} (star: the best)",
                 fontsize=TITLE_PT)
    fig.tight_layout()
    return fig


def slot(d: dict[str, Any]) -> dict[str, Any]:
    return {k: v for k, v in d.items() if k != "important"}
