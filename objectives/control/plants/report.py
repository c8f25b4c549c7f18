"""Run report of the generic loop: responses, Bode plot with margins, the requirements.

Written by :meth:`.loop.SISOLoop.finalize` (the objective's ``finalize`` hook) into the run directory:

- ``figures/response.png``: per scenario, the output against the reference and the control signal of
  the defaults and the tuned controller on the nominal plant; for an LTI plant with a limit the tuned
  one's small-signal response (dashed, :mod:`.robustness`: the loop without limits at the scenario's
  amplitude), and with ``uncertainty`` its response on the other models of the tuning set (thin grey, at
  most 24); the legend sits below the plots, off the curves;
- ``figures/bode.png`` (linear plants): magnitude and phase of the loop ``L`` of both on the nominal
  plant (and the tuned one on the other tuning models), the tuned one's margins marked;
- ``requirements.md``: the pass/fail table per requirement, scenario and model set (:mod:`.tables`), the
  requirements met only through saturation, what each quantity is and where it is measured, the model
  sets, and with ``uncertainty`` the held-out summary and the margins per model.

It returns what the run keeps in ``best.yaml`` and prints: the table as text (``summary_table``, the
terminal), the report's lead (``headline_md``: gains and table, :func:`tuner.report` shows it first), every
metric's name in words with its unit (``metric_words``, the report's metric tables),
whether every requirement is met, small-signal too, and the held-out summary. A score the defaults
could not get (a failed evaluation) is given as its reason, never as the failure's penalty value.
Every figure is an explicit ``Figure`` (:mod:`objectives.control.figure`): the process's matplotlib
backend and rcParams are left as the caller set them.
"""

from __future__ import annotations

import math
import pathlib
from typing import Any

import numpy as np

from objectives.control.design import evaluate_loop
from objectives.control.figure import new_figure, save_figure
from objectives.control.plants.requirements import REQUIREMENTS, metric_words
from objectives.control.plants.robustness import Assessment, assess, saturation_only, small_signal_method
from objectives.control.plants.tables import (
    fmt,
    heldout_summary,
    lead_table,
    markdown_table,
    requirement_rows,
    saturation_notes,
    text_table,
)
from tuner.safe_io import write_atomic

__all__ = ["write_report", "plot_responses", "plot_bode"]

#: at most this many other models drawn thin in the figures
_MAX_MODELS_DRAWN = 24


def plot_responses(loop: Any, runs: dict[str, dict[str, Any]], path: pathlib.Path) -> pathlib.Path:
    """Per scenario (a row each): output and reference, control signal (module docstring)."""
    n_s = len(loop.cases)
    fig = new_figure((10, 2.6 * n_s + 1.2))
    ax = np.atleast_2d(fig.subplots(n_s, 2, squeeze=False))
    out = loop.plant.output
    tuned = runs.get("tuned")
    cp_t = loop.coeffs(tuned) if tuned is not None else None
    small = loop.runner(loop.models, linear=True) if cp_t is not None else None
    cp_lin = loop.linear_coeffs(tuned) if tuned is not None else None
    show_small = tuned is not None and (loop._real.limited or not np.array_equal(cp_t, cp_lin)) and loop.linear
    for s, case in enumerate(loop.cases):
        t = case.signals.t
        ay, au = ax[s, 0], ax[s, 1]
        if tuned is not None:
            for m in range(1, min(len(loop.models), _MAX_MODELS_DRAWN + 1)):
                tr = loop._runner.trace(cp_t, m, s)
                ay.plot(t, tr["y"][:, out], color="0.75", lw=0.6, label="tuned, other tuning models")
                au.plot(t, tr["u"][:, 0], color="0.75", lw=0.6)
        for (label, params), color in zip(runs.items(), ("tab:blue", "tab:red")):
            try:
                tr = loop._runner.trace(loop.coeffs(params), 0, s)
            except ValueError:
                continue
            ay.plot(t, tr["y"][:, out], color=color, label=label)
            au.plot(t, tr["u"][:, 0], color=color, lw=0.9)
        if show_small:
            tr = small.trace(cp_lin, 0, s)
            ay.plot(t, tr["y"][:, out], color="tab:red", ls="--", lw=0.9, label="tuned, small signal (no limits)")
            au.plot(t, tr["u"][:, 0], color="tab:red", ls="--", lw=0.8)
        ay.plot(t, case.signals.r, "k:", label="reference")
        if np.any(case.signals.load != 0):
            au.plot(t, case.signals.load, "k--", lw=0.8, label="load disturbance")
        ay.set_ylabel("output y")
        au.set_ylabel("control u")
        title = f"scenario {case.name}" if n_s > 1 else "scenario"
        ay.set_title(title, fontsize=9)
        for a in (ay, au):
            a.grid(True, alpha=0.3)
    ax[-1, 0].set_xlabel("time (s)")
    ax[-1, 1].set_xlabel("time (s)")
    rect = _legend_below(fig, ax.ravel(), 2.6 * n_s + 1.2, 3)
    fig.suptitle(f"closed loop, controller {loop.controller}, plant {loop.plant.model} (nominal model)", fontsize=10)
    return save_figure(fig, path, rect=rect)


def _legend_below(fig: Any, axes: Any, height_in: float, ncol: int) -> tuple[float, float, float, float]:
    """One legend for ``axes`` (each label once) below the plots, where it covers no curve; returns the
    rectangle the axes are laid out in (:func:`objectives.control.figure.save_figure`)."""
    seen: dict[str, Any] = {}
    for a in axes:
        for h, lab in zip(*a.get_legend_handles_labels()):
            seen.setdefault(lab, h)
    rows = max(1, math.ceil(len(seen) / ncol))
    fig.legend(list(seen.values()), list(seen), loc="lower center", ncol=min(ncol, max(1, len(seen))), fontsize=8,
               frameon=False)
    return 0.0, (0.15 + 0.2 * rows) / height_in, 1.0, 1.0 - 0.3 / height_in


def plot_bode(loop: Any, runs: dict[str, dict[str, Any]], path: pathlib.Path) -> pathlib.Path:
    fig = new_figure((8, 6.6))
    ax = fig.subplots(2, 1, sharex=True)
    mg: dict[str, float] = {}
    tuned = runs.get("tuned")
    if tuned is not None and len(loop.models) > 1:
        w, L = loop.models.loops(loop.ctrl, loop.coeffs(tuned))
        for i, lm in enumerate(L[1:_MAX_MODELS_DRAWN + 1]):
            ax[0].semilogx(w, 20 * np.log10(np.abs(lm)), color="0.75", lw=0.6,
                           label="tuned, other tuning models" if i == 0 else None)
            ax[1].semilogx(w, np.degrees(np.unwrap(np.angle(lm))), color="0.75", lw=0.6)
    for (label, params), color in zip(runs.items(), ("tab:blue", "tab:red")):
        try:
            cp = loop.coeffs(params)
        except ValueError:
            continue
        w, L = loop.models.loops(loop.ctrl, cp)
        mg = loop.loop_margins(params)
        ax[0].semilogx(w, 20 * np.log10(np.abs(L[0])), color=color,
                       label=f"{label}: GM {mg['gm_db']:.3g} dB, PM {mg['pm_deg']:.3g} deg, Ms {mg['ms']:.3g}")
        ax[1].semilogx(w, np.degrees(np.unwrap(np.angle(L[0]))), color=color)
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
    for a in ax:
        a.grid(True, which="both", alpha=0.3)
    ax[0].set_title("loop transfer function L = C P (broken at the plant input), nominal model", fontsize=10)
    return save_figure(fig, path, rect=_legend_below(fig, ax[:1], 6.6, 1))


def _glossary(loop: Any) -> list[str]:
    keys = list(dict.fromkeys(k for k, _ in loop.check_keys()))
    return [f"- **{REQUIREMENTS[k].words}** (`{k}`, {REQUIREMENTS[k].unit}): {REQUIREMENTS[k].where}." for k in keys]


def _sets_md(loop: Any) -> list[str]:
    unc = loop.uncertainty_block
    md = [f"- tuning set: {loop.models.describe()}; each scenario on every model; cost aggregated "
          f"({loop._agg.text()})"]
    if unc is not None:
        md.append("- uncertain parameters: " + "; ".join(f"`{d.name}` {d.text()}" for d in unc.dists))
        hs = loop.heldout()
        md.append(f"- held-out set: {hs.describe()}, never seen by the tuning")
    return md


def _heldout_md(loop: Any, tuned: Assessment, defaults: Assessment) -> list[str]:
    if tuned.heldout is None:
        return []
    t, d = heldout_summary(tuned.heldout), heldout_summary(defaults.heldout)
    names = [("pass_rate", "models meeting every requirement", lambda v: f"{100 * v:.1f} %"),
             ("cost_mean", "cost, mean over models", fmt), ("cost_median", "cost, median", fmt),
             ("cost_p95", "cost, 95th percentile", fmt), ("cost_max", "cost, worst model", fmt),
             ("ms_max", "maximum sensitivity Ms, worst model", fmt),
             ("gm_db_min", "gain margin (dB), worst model", fmt),
             ("pm_deg_min", "phase margin (deg), worst model", fmt)]
    md = ["## Held-out models", "", f"The tuned and the default controller on the held-out set "
          f"({loop.heldout().describe()}).", "", "| quantity | tuned | defaults |", "|---|---|---|"]
    for k, words, f in names:
        if k in t or k in d:
            md.append(f"| {words} | {f(t[k]) if k in t else '-'} | {f(d[k]) if k in d else '-'} |")
    return md + [""]


def _margins_md(loop: Any, tuned: Assessment) -> list[str]:
    res = tuned.tuning
    if not res.margins or len(loop.models) == 1:
        return []
    md = ["## Margins per model (tuning set, tuned controller)", "",
          "| model | perturbed values | Ms | gain margin (dB) | phase margin (deg) | largest closed-loop pole |",
          "|---|---|---|---|---|---|"]
    for lab, vals, mg in zip(loop.models.labels, loop.models.values, res.margins):
        shown = ", ".join(f"{k} = {v:.4g}" for k, v in vals.items())
        md.append(f"| {lab} | {shown} | {fmt(mg['ms'])} | {fmt(mg['gm_db'])} | {fmt(mg['pm_deg'])} | "
                  f"{fmt(mg['cl_pole_max'])} |")
    return md + [""]


def _gains_md(loop: Any, best: dict[str, Any]) -> list[str]:
    units = {p.name: p.unit for p in loop.decl}
    rows = [f"| {k} | {fmt(v) if isinstance(v, float) else v} | {units.get(k, '')} |" for k, v in best.items()]
    return ["| gain | value | unit |", "|---|---|---|", *rows]


def write_report(loop: Any, run_dir: pathlib.Path, init: dict[str, Any], best: dict[str, Any]) -> dict[str, Any]:
    fig_dir = run_dir / "figures"
    runs = {"defaults": init, "tuned": best}
    ev0, ev1 = evaluate_loop(loop, init), evaluate_loop(loop, best)
    out: dict[str, Any] = {"initial_status": ev0.status}
    if ev0.status == "ok":
        out["initial_fitness"] = ev0.fitness
    else:  # never the failure's penalty as if it were a cost
        out["initial_error"] = ev0.error
    out["best_fitness"] = ev1.fitness if ev1.status == "ok" else math.nan
    keys = {*ev1.metrics, *(k.rpartition(".")[2] for k in ev1.metrics)}
    out["metric_words"] = {k: metric_words(k) for k in sorted(keys)}
    for k in ("iae", "overshoot_pct", "settling_time_s", "ms", "gm_db", "pm_deg", "peak_u"):
        if k in ev1.metrics:
            out[f"best_{k}"] = ev1.metrics[k]
            out[f"initial_{k}"] = ev0.metrics.get(k, math.nan)
            out["metric_words"].update({f"best_{k}": f"tuned: {metric_words(k)}",
                                        f"initial_{k}": f"defaults: {metric_words(k)}"})
    try:
        plot_responses(loop, runs, fig_dir / "response.png")
        if loop.linear:
            plot_bode(loop, runs, fig_dir / "bode.png")
    except ValueError:  # a design that cannot be built (defaults outside the plant's reach): no figure
        pass
    tuned, defaults = assess(loop, "tuned", best), assess(loop, "defaults", init)
    rows = requirement_rows(loop, tuned, defaults)
    notes = saturation_notes(loop, tuned)
    small = small_signal_method(loop) if tuned.small is not None else "no actuator or controller limit: none needed"
    md = ["# Requirements", ""]
    if rows:
        md += ["Every requirement per scenario and model set: the tuned controller's worst value over the set's "
               "models and whether it is met (on every tuning model; the pass rate over the held-out models), the "
               "same small-signal, and the defaults'.", "", markdown_table(rows)]
        md += [f"**{n[0].upper() + n[1:]}.**" for n in notes] + ([""] if notes else [])
    else:
        md += ["None given (`objective.requirements`, or a scenario's own; `tuner describe requirements`).", ""]
    md += [f"Small signal: {small}.", ""]
    md += ["## Model sets", "", *_sets_md(loop), ""]
    if rows:
        md += ["## What each requirement measures", "", *_glossary(loop), ""]
    md += _heldout_md(loop, tuned, defaults) + _margins_md(loop, tuned)
    write_atomic(run_dir / "requirements.md", "\n".join(md), fsync=False)
    met = bool(rows) and all(r[5] == "yes" for r in rows if r[2].startswith("tuning"))
    out["requirements_met"] = met if rows else True
    if tuned.small is not None and rows:
        out["small_signal_met"] = not saturation_only(tuned) and all(
            r[7] in ("yes", "-") for r in rows if r[2].startswith("tuning"))
    for k, v in heldout_summary(tuned.heldout).items():
        out[f"heldout_{k}"] = v
    if rows:
        text = text_table(rows)
        out["summary_table"] = "requirements (tuning set: " + loop.models.describe() + ")\n" + text + \
            "".join(f"\nwarning: {n}" for n in notes)
    lead = ["## Tuned controller", "", *_gains_md(loop, best), ""]
    if rows:
        lead += ["## Requirements", "", lead_table(rows)] + [f"**{n[0].upper() + n[1:]}.**" for n in notes]
        lead += ["", "Details: [requirements.md](requirements.md) (the defaults' values, what each requirement "
                 "measures, the model sets" + (", held-out models" if tuned.heldout is not None else "") + ")."]
    out["headline_md"] = "\n".join(lead) + "\n"
    out["metric_words"].update({k: w for k, w in _RESULT_WORDS.items() if k in out})
    return out


#: the results above in words (the report's "Other results")
_RESULT_WORDS = {
    "initial_status": "defaults: evaluation status", "requirements_met": "every requirement met on the tuning set",
    "small_signal_met": "every requirement met small-signal too",
    "heldout_pass_rate": "held-out models meeting every requirement (fraction)",
    "heldout_cost_mean": "held-out models: cost, mean", "heldout_cost_median": "held-out models: cost, median",
    "heldout_cost_p95": "held-out models: cost, 95th percentile", "heldout_cost_max": "held-out models: cost, worst",
    "heldout_ms_max": "held-out models: maximum sensitivity Ms, worst",
    "heldout_gm_db_min": "held-out models: gain margin (dB), worst",
    "heldout_pm_deg_min": "held-out models: phase margin (deg), worst",
}
