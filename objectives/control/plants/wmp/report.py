"""The pendulum's run report: initial against tuned scores, the response figure (thesis Figs. 2.16-2.18),
fuzzy action surfaces (Figs. 2.19-2.20), the step responses as ``traces.json`` (the interactive report,
:mod:`tuner.interactive`) and the tuned response as ``response_best.npz``.

Every figure is an explicit ``Figure`` (:mod:`objectives.control.figure`): the process's matplotlib
backend and rcParams are left as the caller set them.
"""

from __future__ import annotations

import json
import math
import pathlib
from collections.abc import Mapping
from typing import Any

import numpy as np

from objectives.control.design import evaluate_loop
from objectives.control.figure import new_figure, save_figure
from objectives.control.plants.wmp.model import STATUS_OK
from tuner.safe_io import write_atomic

__all__ = ["plot_surfaces", "plot_response", "save_response", "traces_doc", "write_report"]

#: the metrics of the comparison the sweep tables collect (``train.*`` columns)
_COMPARED = ("peak_theta3_deg", "peak_current_A", "rise_time_nu_s", "rise_time_xi_s", "settle_theta3_s", "mae_nu",
             "mae_xi")

#: samples per plotted series
POINTS = 2000


def traces_doc(obj: Any, before: Mapping[str, Any], after: Mapping[str, Any]) -> dict[str, Any]:
    """Speed, yaw rate, IB angle and current of the initial and the tuned controller against the references.

    ``obj.traces(params)`` gives ``{panel title (unit): {"t", "y", "ref"}}``; a failed simulation (the
    robot fell) is shown for as long as it ran.
    """
    import re

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


def plot_surfaces(
    ctrl: Any, before: Mapping[str, Any], after: Mapping[str, Any], fig_dir: str | pathlib.Path
) -> list[pathlib.Path]:
    """One PNG per fuzzy system of ``ctrl`` (``ctrl.surfaces(values)``): initial (left) vs tuned (right).

    Figs. 2.19 (FLC1 of the protective scheme: proportional tag over speed error and |I_A|) and 2.20
    (FLC2 over IB angle and rate errors). Returns the written paths ``fig_dir/surface_<name>.png``.
    """
    import mpl_toolkits.mplot3d  # noqa: F401 - registers the 3-D projection

    fig_dir = pathlib.Path(fig_dir)
    fig_dir.mkdir(parents=True, exist_ok=True)
    s0, s1 = ctrl.surfaces(dict(before)), ctrl.surfaces(dict(after))
    paths = []
    for name in s0:
        fig = new_figure((11, 4.6))
        for k, (label, s) in enumerate((("initial", s0[name]), ("tuned", s1[name]))):
            ax = fig.add_subplot(1, 2, k + 1, projection="3d")
            X, Y = np.meshgrid(s["x"], s["y"], indexing="ij")
            ax.plot_surface(X, Y, s["z"], cmap="viridis", linewidth=0, antialiased=True)
            ax.set_xlabel(s["x_label"])
            ax.set_ylabel(s["y_label"])
            ax.set_zlabel(s["z_label"])
            ax.set_title(f"{name.upper()} {label}")
        paths.append(save_figure(fig, fig_dir / f"surface_{name}.png", dpi=100))
    return paths


def plot_response(loop: Any, params_before: Mapping[str, Any] | None, params_after: Mapping[str, Any] | None,
                  path: str | pathlib.Path) -> pathlib.Path:
    """Figure like thesis Figs. 2.16-2.18: speed, yaw rate, theta3, current, voltages, before (blue) and
    after (red) tuning. Either set may be ``None`` to plot one response."""
    fig = new_figure((8, 11))
    ax = fig.subplots(5, 1, sharex=True)
    ref = loop._ref
    t = np.arange(ref.shape[0]) * loop.period_s
    for label, params, color in (("before", params_before, "tab:blue"), ("after", params_after, "tab:red")):
        if params is None:
            continue
        s = loop.simulate(params)
        t, y, u = s["t"], s["outputs"], s["voltages"]
        f = loop.evaluation(s, params).fitness
        lab = f"{label} (F={f:.4g})" if s["status"] == STATUS_OK else f"{label} ({s['status_name']})"
        ax[0].plot(t, y[:, 0], color=color, label=lab)
        ax[1].plot(t, np.degrees(y[:, 3]), color=color)
        ax[2].plot(t, np.degrees(y[:, 1]), color=color)
        ax[3].plot(t, y[:, 4], color=color)
        ax[4].plot(t, u[:, 0], color=color, lw=0.8)
        ax[4].plot(t, u[:, 1], color=color, lw=0.8, ls="--")
    ax[0].plot(t, ref[:, 0], "k:", label="reference")
    ax[1].plot(t, np.degrees(ref[:, 1]), "k:")
    for a, lab in zip(ax, ["speed (m/s)", "yaw rate (deg/s)", "theta3 (deg)", "avg. current (A)",
                           "voltages u1, u2-- (V)"]):
        a.set_ylabel(lab)
        a.grid(True, alpha=0.3)
    ax[0].legend(loc="upper right")
    ax[-1].set_xlabel("time (s)")
    ax[0].set_title(f"WMP closed loop, controller {loop.controller}")
    return save_figure(fig, path)


def save_response(loop: Any, params: Mapping[str, Any] | None, path: str | pathlib.Path) -> pathlib.Path:
    """The closed loop at ``params`` as ``.npz`` (t s, references (N, 2), outputs (N, 5), voltages (N, 2),
    controller name, F): the tuned closed loop kept with the run (``response_best.npz``); a sweep overlays its
    controllers' responses through the objective's ``traces`` hook (the engine's sweep figure)."""
    s = loop.simulate(params)
    path = pathlib.Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fitness = loop.evaluation(s, params).fitness
    # never through a link or into a hard-linked file of the run directory (tuner.safe_io)
    write_atomic(path, lambda fh: np.savez(fh, t=s["t"], references=s["references"], outputs=s["outputs"],
                                           voltages=s["voltages"], n_done=s["n_done"], controller=loop.controller,
                                           fitness=fitness), fsync=False)
    return path


def write_report(loop: Any, run_dir: pathlib.Path, init: dict[str, Any], best: dict[str, Any]) -> dict[str, Any]:
    """After a run: the initial parameters' score next to the best one, and report figures.

    Writes ``figures/response.png`` (initial vs tuned closed loop, Figs. 2.16-2.17) and, for controllers
    with ``surfaces`` (the fuzzy ones), ``figures/surface_<flc>.png`` (initial vs tuned action surfaces,
    Figs. 2.19-2.20), ``traces.json`` and ``response_best.npz`` (:func:`save_response`). Returns
    ``initial_fitness``, the initial and best peak IB angle, peak current and rise times,
    ``improvement_pct`` = 100 (F_init - F_opt) / F_init, and ``train`` = {profile: {F, peaks, rise times,
    MAEs}} of the best parameters, which the sweep tables collect as ``train.*`` columns.
    """
    fig_dir = run_dir / "figures"
    ev0, ev1 = evaluate_loop(loop, init), evaluate_loop(loop, best)
    out: dict[str, Any] = {
        "initial_fitness": ev0.fitness,
        "initial_status": ev0.status,
        "initial_error": ev0.error,
        "initial_peak_theta3_deg": ev0.metrics.get("peak_theta3_deg", math.nan),
        "initial_peak_current_A": ev0.metrics.get("peak_current_A", math.nan),
        "best_fitness": ev1.fitness,
        "best_peak_theta3_deg": ev1.metrics.get("peak_theta3_deg", math.nan),
        "best_peak_current_A": ev1.metrics.get("peak_current_A", math.nan),
        "initial_rise_time_nu_s": ev0.metrics.get("rise_time_nu_s", math.nan),
        "best_rise_time_nu_s": ev1.metrics.get("rise_time_nu_s", math.nan),
        "best_rise_time_xi_s": ev1.metrics.get("rise_time_xi_s", math.nan),
        "initial_settle_theta3_s": ev0.metrics.get("settle_theta3_s", math.nan),
        "best_settle_theta3_s": ev1.metrics.get("settle_theta3_s", math.nan),
    }
    if ev0.status == "ok" and ev1.status == "ok" and ev0.fitness > 0:
        out["improvement_pct"] = 100.0 * (ev0.fitness - ev1.fitness) / ev0.fitness
    # the comparison quantities in the per-scenario form the generic sweep tables collect
    # (results.csv / summary.csv columns train.F, train.peak_theta3_deg, ...)
    scenario = loop.profile if isinstance(loop.profile, str) else "profile"
    out["train"] = {scenario: {"F": ev1.fitness, **{k: ev1.metrics.get(k, math.nan) for k in _COMPARED}}}
    plot_response(loop, init, best, fig_dir / "response.png")
    save_response(loop, best, run_dir / "response_best.npz")
    write_atomic(run_dir / "traces.json", json.dumps(traces_doc(loop, init, best), separators=(",", ":")),
                 fsync=False)
    if callable(getattr(loop.ctrl, "surfaces", None)):
        plot_surfaces(loop.ctrl, init, {**loop.fixed, **best}, fig_dir)
    return out
