"""Run report of the MuJoCo loop: responses, requirements and the held-out models.

Written by :meth:`.loop.MujocoLoop.finalize` into the run directory:

- ``figures/response.png``: every output against its reference and every input, defaults and tuned, on the
  nominal model;
- ``requirements.md``: every requirement (limit, tuned, defaults, met; the worst output on every tuning
  model), then, with an ``uncertainty`` block, the held-out models: how many, how each was drawn, the pass
  rate (the run neither failed nor broke a requirement) of the tuned and the default controller, the pass
  rate of every requirement, the cost's median, 95th percentile and worst, and the failures grouped by cause;
- ``figures/held_out.png``: the held-out models' costs, tuned and defaults, sorted (a failed model at the top).

The held-out models were never tuned on (:mod:`.uncertainty`), so their pass rate is the run's honest
figure; the tuning models' numbers are optimistic (they chose the controller). Every figure is an explicit
``Figure`` (:mod:`objectives.control.figure`).
"""

from __future__ import annotations

import math
import os
import pathlib
import re
from collections import Counter
from typing import Any

import numpy as np

from objectives.control.design import evaluate_loop
from objectives.control.figure import new_figure, save_figure
from objectives.control.plants.mujoco.batch import run_all
from objectives.control.plants.mujoco.steps import violated
from objectives.control.plants.requirements import REQUIREMENTS, limit_text
from tuner.objective import Evaluation

__all__ = ["write_report", "held_out_scores", "HeldOut"]


class HeldOut:
    """The held-out scores of one controller: per model its cost (NaN when failed), the reason it failed
    ('' when it passed) and its metrics."""

    def __init__(self, labels: list[str], costs: np.ndarray, why: list[str], metrics: list[dict[str, float]]):
        self.labels, self.costs, self.why, self.metrics = labels, costs, why, metrics

    @property
    def pass_rate(self) -> float:
        return float(np.mean([not w for w in self.why])) if self.why else math.nan

    def stats(self) -> dict[str, float]:
        ok = self.costs[np.isfinite(self.costs) & np.array([not w for w in self.why])]
        q = (lambda p: float(np.percentile(ok, p))) if ok.size else (lambda p: math.nan)
        return {"pass_rate": self.pass_rate, "cost_median": q(50), "cost_p95": q(95),
                "cost_worst": float(np.max(ok)) if ok.size else math.nan}

    def causes(self) -> list[tuple[str, int]]:
        """Failures grouped by cause (numbers and times left out of the grouping)."""
        return Counter(re.sub(r"[-+]?\d[\d.e+-]*", "#", w) for w in self.why if w).most_common()


def requirements_markdown(loop: Any, ev0: Evaluation, ev1: Evaluation) -> str:
    """The requirements table of the defaults' evaluation ``ev0`` and the tuned one ``ev1`` (worst output and
    tuning model), limits and words from the generic loop's requirement table."""
    rows0 = {r["requirement"]: r for r in loop.requirement_rows(ev0)}
    lines = ["| requirement | limit | tuned | met | defaults | met |", "|---|---|---|---|---|---|"]
    for r in loop.requirement_rows(ev1):
        r0 = rows0[r["requirement"]]
        lines.append(f"| {r['what']} | {limit_text(r['requirement'], r['limit'])} | {r['value']:.4g} | "
                     f"{'yes' if r['met'] else 'NO'} | {r0['value']:.4g} | {'yes' if r0['met'] else 'NO'} |")
    return "\n".join(lines) + "\n"


def held_out_scores(loop: Any, params: dict[str, Any], n_threads: int = 0) -> HeldOut | None:
    """The controller of ``params`` on the loop's held-out models (None without ``uncertainty``)."""
    unc = loop._unc
    if unc is None or unc.held_out == 0:
        return None
    cases = unc.held_out_set()
    if loop._held_plants is None:
        loop._held_plants = [loop.model_plant(c) for c in cases]
    try:
        cp = loop.coeffs(params)
    except ValueError as exc:
        why = [f"controller design failed: {exc}"] * len(cases)
        return HeldOut([c.label for c in cases], np.full(len(cases), np.nan), why, [{}] * len(cases))
    n = n_threads or min(4, os.cpu_count() or 1)
    runs = run_all(loop, [(cp, j) for j in range(len(cases))], n, loop._held_plants, cases)
    costs, why, mets = np.full(len(cases), np.nan), [], []
    for j, run in enumerate(runs):
        f, m, w = loop.run_metrics(run)
        costs[j] = f
        why.append(w)
        mets.append(m)
    return HeldOut([c.label for c in cases], costs, why, mets)


def plot_responses(loop: Any, runs: dict[str, dict[str, Any]], path: pathlib.Path) -> pathlib.Path:
    p = loop.plant
    n_panels = p.n_outputs + 1
    fig = new_figure((8, 2.0 * n_panels + 0.6))
    ax = fig.subplots(n_panels, 1, sharex=True, squeeze=False)[:, 0]
    t = loop._sc.t
    for (label, params), color in zip(runs.items(), ("tab:blue", "tab:red")):
        try:
            run = loop.run_case(loop.coeffs(params), 0, loop._data(0))
        except ValueError as exc:
            ax[0].plot([], [], color=color, label=f"{label} (design failed: {str(exc)[:40]})")
            continue
        f, _, why = loop.run_metrics(run)
        lab = f"{label} (cost {f:.4g})" if not why else f"{label} ({why[:48]})"
        n = run["n_done"]
        for i in range(p.n_outputs):
            ax[i].plot(t[:n], run["y"][:n, i], color=color, label=lab if i == 0 else None)
        for i in range(p.n_inputs):
            ax[-1].plot(t[:n], run["u"][:n, i], color=color, lw=0.9, ls=("-", "--", ":", "-.")[i % 4],
                        label=f"{label}: {p.input_names[i]}" if p.n_inputs > 1 else None)
    for i, name in enumerate(p.output_names):
        ax[i].plot(t, loop._sc.r[:, i], "k:", lw=1.0, label="reference" if i == 0 else None)
        ax[i].set_ylabel(name)
        ax[i].grid(True, alpha=0.3)
    ax[-1].set_ylabel("input" if p.n_inputs > 1 else f"input {p.input_names[0]}")
    ax[-1].set_xlabel("time (s)")
    ax[-1].grid(True, alpha=0.3)
    # above the curves, never on them
    ax[0].legend(loc="lower left", bbox_to_anchor=(0.0, 1.02), ncol=3, fontsize=8, frameon=False)
    if p.n_inputs > 1:
        ax[-1].legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=7, frameon=False)
    fig.suptitle(f"{loop.controller} on {pathlib.Path(p.path).name} (nominal model)", fontsize=10)
    save_figure(fig, path)
    return path


def plot_held_out(tuned: HeldOut, defaults: HeldOut | None, path: pathlib.Path) -> pathlib.Path:
    fig = new_figure((8, 3.6))
    ax = fig.subplots()
    for label, h, color in (("tuned", tuned, "tab:red"), ("defaults", defaults, "tab:blue")):
        if h is None:
            continue
        c = np.sort(np.where(np.array([bool(w) for w in h.why]), np.inf, h.costs))
        ok = np.isfinite(c)
        ax.plot(np.flatnonzero(ok), c[ok], ".", color=color, label=f"{label}: pass rate {h.pass_rate:.1%}")
        if (~ok).any():
            top = np.nanmax(c[ok]) if ok.any() else 1.0
            ax.plot(np.flatnonzero(~ok), np.full((~ok).sum(), top), "x", color=color, label=f"{label}: failed")
    ax.set_xlabel("held-out model (sorted by cost)")
    ax.set_ylabel("cost")
    ax.set_yscale("log")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    ax.set_title(f"{len(tuned.why)} held-out models (never tuned on)")
    return save_figure(fig, path)


def _held_out_markdown(loop: Any, tuned: HeldOut, defaults: HeldOut) -> str:
    unc = loop._unc
    dims = unc.dimensions()
    lines = ["", "## Held-out models", "",
             f"{len(tuned.why)} models drawn apart from the tuning set ({unc.summary()}; tuning cost over the "
             f"models: {loop._agg.text().split('models: ')[1]}); uncertain: {dims}. "
             "A model passes when its run neither fails (diverges, leaves its limits) nor breaks a requirement.", "",
             "| | tuned | defaults |", "|---|---|---|"]
    st, sd = tuned.stats(), defaults.stats()
    lines += [f"| pass rate | {st['pass_rate']:.1%} | {sd['pass_rate']:.1%} |",
              f"| cost, median of passing models | {st['cost_median']:.4g} | {sd['cost_median']:.4g} |",
              f"| cost, 95th percentile | {st['cost_p95']:.4g} | {sd['cost_p95']:.4g} |",
              f"| cost, worst passing model | {st['cost_worst']:.4g} | {sd['cost_worst']:.4g} |"]
    for key, lim in loop._req.items():
        sense, what = REQUIREMENTS[key].sense, REQUIREMENTS[key].words
        rate = [np.mean([bool(m) and not violated({key: lim}, m) for m in h.metrics])
                for h in (tuned, defaults)]
        rel = "<=" if sense == "max" else ">="
        lines.append(f"| {what} {rel} {lim:g}: pass rate | {rate[0]:.1%} | {rate[1]:.1%} |")
    for label, h in (("tuned", tuned), ("defaults", defaults)):
        causes = h.causes()
        if causes:
            lines += ["", f"Failures of the {label} controller by cause: "
                      + "; ".join(f"{n} x {c}" for c, n in causes[:6])]
    return "\n".join(lines) + "\n"


def write_report(loop: Any, run_dir: pathlib.Path, init: dict[str, Any], best: dict[str, Any]) -> dict[str, Any]:
    fig_dir = run_dir / "figures"
    ev0, ev1 = evaluate_loop(loop, init), evaluate_loop(loop, best)
    out: dict[str, Any] = {"best_fitness": ev1.fitness, "initial_status": ev0.status}
    if ev0.status == "ok":
        out["initial_fitness"] = ev0.fitness
    else:
        out["initial_error"] = ev0.error
    for k in ("iae", "overshoot_pct", "settling_time_s", "peak_u", "cost_mean", "cost_worst"):
        if k in ev1.metrics:
            out[f"best_{k}"] = ev1.metrics[k]
    plot_responses(loop, {"defaults": init, "tuned": best}, fig_dir / "response.png")
    text = "# Requirements\n\n"
    text += (f"Measured on the {len(loop.cases)} tuning model(s), the worst output on the worst model.\n\n"
             + requirements_markdown(loop, ev0, ev1)) if loop._req else "none given\n"
    out["requirements_met"] = ev1.status == "ok" and all(r["met"] for r in loop.requirement_rows(ev1))
    tuned = held_out_scores(loop, best)
    if tuned is not None:
        defaults = held_out_scores(loop, init)
        text += _held_out_markdown(loop, tuned, defaults)
        plot_held_out(tuned, defaults, fig_dir / "held_out.png")
        st = tuned.stats()
        out.update({"held_out_models": len(tuned.why), "held_out_pass_rate": st["pass_rate"],
                    "held_out_pass_rate_defaults": defaults.pass_rate, "held_out_cost_median": st["cost_median"],
                    "held_out_cost_p95": st["cost_p95"], "tuning_models": len(loop.cases)})
    (run_dir / "requirements.md").write_text(text)
    return out
