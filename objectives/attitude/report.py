"""Report of a filter run: train/test scores side by side and figures of the best candidate.

Figures (``figures/``), and ``traces.json`` (every recording, worst first, for the interactive report):

``euler_<rec>.png``        truth vs estimate roll/pitch/yaw on the worst recording (train or test)
``errors_<rec>.png``       heading and inclination error (deg) on it (:mod:`objectives.attitude.traces`)
``adaptation_<rec>.png``   disturbance measures and the fuzzy scaling factor over time (adaptive
                           filters, like Figs. 8-11 of the FAEKF paper)
``fuzzy_surface.png``      the tuned fuzzy scaling as a surface over two inputs (FAEKF)
"""

from __future__ import annotations

import json
import math
import re
from pathlib import Path
from typing import Any

import numpy as np

from objectives.attitude.objective_options import fitness_label
from objectives.attitude.prepared import Split
from tuner.figures import pyplot
from tuner.safe_io import write_atomic

__all__ = ["filter_report", "summary_table"]

_AX = ("roll", "pitch", "yaw")


def _safe(name: str) -> str:
    return re.sub(r"[^0-9A-Za-z_.-]", "_", name)[:60]


def _rows(scores: Any, split: str) -> list[dict[str, Any]]:
    rows = []
    for name, m in scores.recordings.items():
        row = {"split": split, "recording": name}
        row.update({k: v for k, v in m.items()})
        rows.append(row)
    return rows


def summary_table(filter_name: str, train: Any, test: Any, metric: str, label: str | None = None) -> str:
    """A plain-text table: filter, train and test fitness, mean per-axis RMSE (deg) and BROAD RMSE.

    ``label``: how the fitness is made when it is not the plain ``metric`` (an aggregation over recordings
    or a prior); it is printed under the table, so the fitness column is not read as the mean of the RMSEs.
    """
    def mean_of(scores, key):
        vals = [m.get(key) for m in scores.recordings.values() if m.get(key) is not None]
        return float(np.mean(vals)) if vals else math.nan

    head = (f"{'filter':10s} {'split':6s} {metric:>18s} {'roll':>7s} {'pitch':>7s} {'yaw':>7s} {'total':>7s}"
            "  (RMSE, deg)")
    lines = [head, "-" * len(head)]
    for split, s in (("train", train), ("test", test)):
        if not s or not s.recordings:
            continue
        vals = [mean_of(s, f"{a}_rmse_deg") for a in _AX] + [mean_of(s, "total_rmse_deg")]
        lines.append(f"{filter_name:10s} {split:6s} {s.fitness:18.6g} " + " ".join(f"{v:7.3f}" for v in vals))
    if label and label != metric:
        lines.append(f"{metric}: the fitness, {label}; roll..total: means over the recordings")
    return "\n".join(lines)


def filter_report(obj: Any, run_dir: Path, best: dict[str, Any]) -> dict[str, Any]:
    """Score ``best`` on train and test recordings, write figures, return the numbers for best.yaml."""
    import pandas as pd

    from tuner.report import md_table

    figs = run_dir / "figures"
    figs.mkdir(parents=True, exist_ok=True)
    # the figures show every recording (worst first): their estimates are kept unless traces are off
    limit = None if obj.report.get("traces", True) else 0
    test = obj.score(best, "test", keep_outputs=True, outputs_limit=limit) if obj.test_specs else None
    train = obj.score(best, "train", keep_outputs=True, outputs_limit=limit)
    out: dict[str, Any] = {
        "train_fitness": train.fitness,
        "test_fitness": test.fitness if test else None,
        "train": train.recordings,
    }
    if test:
        out["test"] = test.recordings
    table = summary_table(obj.filter, train, test, obj.metric,
                          fitness_label(obj.metric, obj.metric_options, getattr(obj, "prior", None)))
    out["summary_table"] = table
    rows = _rows(train, "train") + (_rows(test, "test") if test else [])
    df = pd.DataFrame(rows)
    write_atomic(run_dir / "scores.csv", df.to_csv(index=False), fsync=False)
    md = ["Train and test scores of the best parameters (RMSE in degrees; test recordings were not used "
          "for tuning).", "", "```", table, "```", "", md_table(df, ".4g")]
    if obj.report.get("per_trial_optimum"):
        po = per_trial_optimum(obj, best, split="test" if test else "train",
                               budget=int(obj.report.get("per_trial_budget", 120)))
        out["per_trial_optimum"] = po
        md += ["", "Trial-agnostic parameters (tuned on the training recordings) next to each recording's "
               "own optimum (a small PSO per recording):", "", _per_trial_md(po)]
    out["tables_md"] = "\n".join(md)

    # static figures of the worst recording; traces.json holds every recording for the interactive page
    items = [(split, rec, sc.outputs[rec.name], sc.recordings.get(rec.name, {}))
             for split, sc in (("train", train), ("test", test)) if sc is not None
             for rec in obj.recordings(split) if rec.name in sc.outputs]
    if obj.report.get("traces", True) and items:
        from objectives.attitude.traces import traces_doc, worst_first

        _, rec, res, _ = items[worst_first([(s, r.name, m) for s, r, _, m in items], obj.metric)[0]]
        _plot_traces(rec, res, figs, rec.name)
        if "K" in res.diagnostics:
            _plot_adaptation(rec, res, figs, rec.name)
        doc = traces_doc(items, obj.metric, [f"euler_{_safe(rec.name)}.png", f"errors_{_safe(rec.name)}.png"])
        write_atomic(run_dir / "traces.json", json.dumps(doc, separators=(",", ":"), allow_nan=False), fsync=False)
    fs = getattr(obj.make_filter(best), "membership_table", None)
    if callable(fs):
        try:
            _plot_fuzzy_surface(obj.make_filter(best), figs / "fuzzy_surface.png")
        except (ValueError, AttributeError, TypeError):
            pass
    return out


def _euler_deg(q: np.ndarray) -> np.ndarray:
    from objectives.attitude.quaternion import euler_zyx

    return np.degrees(euler_zyx(q))


def _plot_traces(rec, res, figs: Path, name: str) -> None:
    from objectives.attitude.traces import error_angles_deg

    plt = pyplot()
    t = rec.time
    step = max(1, rec.n // 20000)  # plot at most ~20k points per line
    est = _euler_deg(res.quat[::step])
    tru = _euler_deg(rec.quat[::step]) if rec.quat is not None else None
    fig, axes = plt.subplots(3, 1, figsize=(8, 6.5), sharex=True, dpi=100)
    for j, ax in enumerate(axes):
        if tru is not None:
            ax.plot(t[::step], tru[:, j], lw=1.2, label="truth", color="k")
        ax.plot(t[::step], est[:, j], lw=0.9, label="estimate", color="tab:red", alpha=0.85)
        ax.set_ylabel(f"{_AX[j]} (deg)")
        ax.grid(alpha=0.3)
    axes[0].legend(loc="upper right", fontsize=8)
    axes[0].set_title(f"{name}: truth vs estimate ({rec.frame})", fontsize=9)
    axes[-1].set_xlabel("time (s)")
    fig.tight_layout()
    write_atomic(figs / f"euler_{_safe(name)}.png", lambda fh: fig.savefig(fh, format="png"), fsync=False)
    plt.close(fig)
    if rec.quat is None:
        return
    head, incl = error_angles_deg(res.quat[::step], rec.quat[::step])
    fig, ax = plt.subplots(figsize=(8, 3.2), dpi=100)
    ax.plot(t[::step], head, lw=0.8, label="heading error")
    ax.plot(t[::step], incl, lw=0.8, label="inclination error")
    ax.set_xlabel("time (s)")
    ax.set_ylabel("error (deg)")
    ax.set_title(f"{name} (worst recording): heading and inclination error", fontsize=9)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    write_atomic(figs / f"errors_{_safe(name)}.png", lambda fh: fig.savefig(fh, format="png"), fsync=False)
    plt.close(fig)


def _plot_adaptation(rec, res, figs: Path, name: str) -> None:
    plt = pyplot()
    d = res.diagnostics
    keys = [k for k in ("vib_freq_hz", "ext_acc", "mag_pert", "K") if k in d]
    fig, axes = plt.subplots(len(keys), 1, figsize=(8, 1.7 * len(keys) + 0.6), sharex=True, dpi=100)
    axes = np.atleast_1d(axes)
    step = max(1, rec.n // 20000)
    labels = {"vib_freq_hz": "vibration (Hz)", "ext_acc": "ext. acc. (g)", "mag_pert": "mag. pert.",
              "K": "fuzzy scale K_R"}
    for ax, k in zip(axes, keys):
        ax.plot(rec.time[::step], np.asarray(d[k])[::step], lw=0.9)
        ax.set_ylabel(labels[k], fontsize=8)
        ax.grid(alpha=0.3)
    if "K" in keys:
        axes[-1].set_yscale("log")
    axes[0].set_title(f"{name}: disturbance measures and fuzzy scaling", fontsize=9)
    axes[-1].set_xlabel("time (s)")
    fig.tight_layout()
    write_atomic(figs / f"adaptation_{_safe(name)}.png", lambda fh: fig.savefig(fh, format="png"), fsync=False)
    plt.close(fig)


def _plot_fuzzy_surface(flt, path: Path) -> None:
    """K_R over (vibration frequency, external acceleration) with no magnetic perturbation."""
    from objectives.attitude.filters.ekf import Disturbances

    plt = pyplot()
    f = np.linspace(0, float(flt.values.get("f_thr", 10.0)), 41)
    a = np.linspace(0, 1.0, 41)
    F, A = np.meshgrid(f, a)
    dist = Disturbances(F.ravel().copy(), A.ravel().copy(), np.zeros(F.size))
    K = np.asarray(flt.scale(dist)).reshape(F.shape)
    fig = plt.figure(figsize=(6, 4.5), dpi=100)
    ax = fig.add_subplot(projection="3d")
    ax.plot_surface(F, A, K, cmap="viridis", linewidth=0)
    ax.set_xlabel("vibration (Hz)")
    ax.set_ylabel("ext. acc. (g)")
    ax.set_zlabel("K_R")
    ax.set_title("tuned fuzzy scaling of R (no magnetic perturbation)", fontsize=9)
    fig.tight_layout()
    write_atomic(path, lambda fh: fig.savefig(fh, format="png"), fsync=False)
    plt.close(fig)


def per_trial_optimum(obj: Any, best: dict[str, Any], split: Split = "test", budget: int = 120) -> dict[str, Any]:
    """Each recording's own optimum (a small serial PSO per recording) next to the given parameters.

    Shows how much a trial-agnostic parameter set loses against per-trial tuning (BROAD's TAGP vs
    per-trial minimum).
    """
    from tuner.loop import minimize
    from tuner.optimizers import PSO

    space = obj.default_space()
    out: dict[str, Any] = {}
    recs = obj.recordings(split)
    for i, rec in enumerate(recs):
        single = type(obj)(obj.filter, [], [], dict(obj.fixed), obj.metric, dict(obj.metric_options), obj.q0,
                           obj.warmup_s, {}, obj.base_dir).with_recordings(train=[rec])
        agnostic = single.score(best).fitness
        pop = max(6, min(12, budget // 10))
        opt = PSO(space.dim, np.random.default_rng(i), population=pop, generations=max(1, budget // pop),
                  inertia="linear", c1=1.5, c2=1.5, x0=space.encode({k: best[k] for k in space.free_names}))
        res = minimize(single, space, opt)  # serial, in this process
        own = res.best.params if res.best else {k: best[k] for k in space.free_names}
        out[rec.name] = {"agnostic": float(agnostic), "own_optimum": float(min(res.fitness, agnostic)),
                         "own_params": {k: v for k, v in own.items() if k in space.free_names}}
    return out


def _per_trial_md(po: dict[str, Any]) -> str:
    lines = ["| recording | trial-agnostic | own optimum | loss |", "|---|---|---|---|"]
    for name, d in po.items():
        loss = d["agnostic"] / d["own_optimum"] - 1 if d["own_optimum"] > 0 else math.nan
        lines.append(f"| {name} | {d['agnostic']:.4g} | {d['own_optimum']:.4g} | {loss:+.1%} |")
    return "\n".join(lines)
