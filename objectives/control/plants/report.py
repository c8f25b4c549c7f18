"""Run report of the generic loop: responses, Bode plot with margins, requirements table.

Written by :meth:`LoopObjective.finalize` into the run directory:

- ``figures/response.png``: reference, output and control signal of the defaults and the tuned
  controller over the scenario (a step response, and the load-disturbance response if it has one);
- ``figures/bode.png`` (LTI plants): magnitude and phase of the loop ``L`` of both, with the gain and
  phase margins of the tuned one marked;
- ``requirements.md``: every requirement with its limit, the tuned value and whether it is met,
  next to the defaults' values.
"""

from __future__ import annotations

import math
import pathlib
from typing import Any

import numpy as np

from tuner.safe_io import write_atomic

__all__ = ["write_report"]


def _fig():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _save(fig, path: pathlib.Path) -> pathlib.Path:
    """Lay out, write as PNG at 110 dpi (creating the folder), close."""
    import matplotlib.pyplot as plt

    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    write_atomic(path, lambda fh: fig.savefig(fh, format="png", dpi=110), fsync=False)
    plt.close(fig)
    return path


def plot_responses(obj: Any, runs: dict[str, dict[str, Any]], path: pathlib.Path) -> pathlib.Path:
    plt = _fig()
    fig, ax = plt.subplots(2, 1, figsize=(8, 6), sharex=True)
    t = obj._sc.t
    for (label, params), color in zip(runs.items(), ("tab:blue", "tab:red")):
        s = obj.simulate(params)
        ev = obj(params)
        lab = f"{label} (cost {ev.fitness:.4g})" if ev.status == "ok" else f"{label} ({ev.error[:40]})"
        ax[0].plot(t, s["y"][:, obj._plant.output], color=color, label=lab)
        ax[1].plot(t, s["u"][:, 0], color=color, lw=0.9)
    ax[0].plot(t, obj._sc.r, "k:", label="reference")
    if np.any(obj._sc.load != 0):
        ax[1].plot(t, obj._sc.load, "k--", lw=0.8, label="load disturbance")
        ax[1].legend(loc="best")
    ax[0].set_ylabel("output y")
    ax[1].set_ylabel("control u")
    ax[1].set_xlabel("time (s)")
    ax[0].legend(loc="best")
    for a in ax:
        a.grid(True, alpha=0.3)
    ax[0].set_title(f"closed loop, controller {obj.controller}, plant {obj._plant.model}")
    return _save(fig, path)


def plot_bode(obj: Any, runs: dict[str, dict[str, Any]], path: pathlib.Path) -> pathlib.Path:
    from objectives.control.plants.analysis import loop_response

    plt = _fig()
    fig, ax = plt.subplots(2, 1, figsize=(8, 6), sharex=True)
    w = obj._omega
    mg: dict[str, float] = {}
    for (label, params), color in zip(runs.items(), ("tab:blue", "tab:red")):
        L = loop_response(obj._ctrl, obj.coeffs(params), obj._plant, w, obj._pr)
        mg = obj.loop_margins(params)
        ax[0].semilogx(w, 20 * np.log10(np.abs(L)), color=color,
                       label=f"{label}: GM {mg['gm_db']:.3g} dB, PM {mg['pm_deg']:.3g} deg, Ms {mg['ms']:.3g}")
        ax[1].semilogx(w, np.degrees(np.unwrap(np.angle(L))), color=color)
    ax[0].axhline(0, color="k", lw=0.6)
    ax[1].axhline(-180, color="k", lw=0.6)
    if math.isfinite(mg.get("wc_rad_s", math.nan)):
        ax[1].axvline(mg["wc_rad_s"], color="tab:red", ls=":")
        ax[1].annotate(f"PM {mg['pm_deg']:.3g} deg", (mg["wc_rad_s"], -180 + mg["pm_deg"]), color="tab:red")
    if math.isfinite(mg.get("w180_rad_s", math.nan)):
        ax[0].axvline(mg["w180_rad_s"], color="tab:red", ls=":")
        ax[0].annotate(f"GM {mg['gm_db']:.3g} dB", (mg["w180_rad_s"], -mg["gm_db"]), color="tab:red")
    ax[0].set_ylabel("|L| (dB)")
    ax[1].set_ylabel("arg L (deg)")
    ax[1].set_xlabel("frequency (rad/s)")
    ax[0].legend(loc="lower left", fontsize=8)
    for a in ax:
        a.grid(True, which="both", alpha=0.3)
    ax[0].set_title("loop transfer function L = C P (broken at the plant input)")
    return _save(fig, path)


def requirements_markdown(obj: Any, init: dict[str, Any], best: dict[str, Any]) -> str:
    rows0 = {r["requirement"]: r for r in obj.requirement_rows(init)}
    lines = ["| requirement | limit | tuned | met | defaults | met |", "|---|---|---|---|---|---|"]
    for r in obj.requirement_rows(best):
        r0 = rows0[r["requirement"]]
        lines.append(f"| {r['what']} | {'<=' if r['requirement'].startswith('max') else '>='} {r['limit']:g} | "
                     f"{r['value']:.4g} | {'yes' if r['met'] else 'NO'} | {r0['value']:.4g} | "
                     f"{'yes' if r0['met'] else 'NO'} |")
    return "\n".join(lines) + "\n"


def write_report(obj: Any, run_dir: pathlib.Path, init: dict[str, Any], best: dict[str, Any]) -> dict[str, Any]:
    fig_dir = run_dir / "figures"
    runs = {"defaults": init, "tuned": best}
    ev0, ev1 = obj(init), obj(best)
    out: dict[str, Any] = {"initial_fitness": ev0.fitness, "initial_status": ev0.status, "initial_error": ev0.error,
                           "best_fitness": ev1.fitness}
    for k in ("iae", "overshoot_pct", "settling_time_s", "ms", "gm_db", "pm_deg", "peak_u"):
        if k in ev1.metrics:
            out[f"best_{k}"] = ev1.metrics[k]
            out[f"initial_{k}"] = ev0.metrics.get(k, math.nan)
    try:
        plot_responses(obj, runs, fig_dir / "response.png")
        if obj.lti:
            plot_bode(obj, runs, fig_dir / "bode.png")
    except ValueError:  # a design that cannot be built (defaults outside the plant's reach): no figure
        pass
    write_atomic(run_dir / "requirements.md", "# Requirements\n\n" + (requirements_markdown(obj, init, best)
                                                                      if obj._req else "none given\n"), fsync=False)
    out["requirements_met"] = not any(not r["met"] for r in obj.requirement_rows(best))
    return out
