"""Report figures: convergence, fitness against each parameter, parallel coordinates, sweep comparisons.

Every figure is drawn for a page about 1100 px wide (``WIDTH_IN`` inches at ``DPI``), so that the
HTML report shows it at its natural size with 10-point text. Parameters are drawn in the coordinate
the optimiser searched: log axes for log-scaled parameters, the search bounds as lines, and, where
parameters share one axis, unit-cube coordinates (0 = low bound, 1 = high bound) through
:meth:`tuner.space.Real.to_unit`. Failed evaluations (penalty fitness) are left out of fitness axes
and counted in the titles.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from tuner.space import Space

__all__ = ["pyplot", "convergence_table", "plot_convergence", "plot_fitness_vs_params", "plot_parallel_coordinates",
           "sweep_figures", "WIDTH_IN", "DPI"]

WIDTH_IN = 10.5
DPI = 100


def pyplot():
    """``matplotlib.pyplot`` on the Agg backend (files only, no display), quiet and with the house font sizes.

    The font manager's "findfont: Font family ... not found" lines, which a fresh environment prints while
    matplotlib builds its font cache, say nothing a user can act on: they are silenced.
    """
    import logging

    import matplotlib

    matplotlib.use("Agg")
    logging.getLogger("matplotlib.font_manager").setLevel(logging.ERROR)
    import matplotlib.pyplot as plt

    plt.rcParams.update({"font.size": 10, "axes.titlesize": 10, "axes.labelsize": 10, "legend.fontsize": 9})
    return plt


def _save(fig, path: Path) -> Path:
    """Save through a temporary file and a rename, never through a link (:func:`tuner.safe_io.write_atomic`)."""
    from tuner.safe_io import check_not_link, write_atomic

    path = Path(path)
    check_not_link(path.parent)
    path.parent.mkdir(parents=True, exist_ok=True)
    write_atomic(path, lambda fh: fig.savefig(fh, dpi=DPI, format=path.suffix.lstrip(".") or "png"), fsync=False)
    pyplot().close(fig)
    return path


def _plain_log_labels(axis) -> None:
    """``1e-05`` instead of mathtext ``10^{-5}``, no minor ticks: both cost most of a figure's drawing time."""
    from matplotlib.ticker import FuncFormatter, NullLocator

    axis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:g}"))
    axis.set_minor_locator(NullLocator())  # minor ticks of log axes: hundreds of Tick objects, no information


def _log_y_if_wide(ax, values: np.ndarray) -> None:
    v = np.asarray(values, float)
    v = v[np.isfinite(v)]
    if len(v) and v.min() > 0 and v.max() / v.min() > 20:
        ax.set_yscale("log")
        _plain_log_labels(ax.yaxis)


def load_history(run_dir: Path) -> pd.DataFrame:
    """``history.csv`` as a frame; a missing or unparsable file raises :class:`tuner.records.RunError`."""
    import io

    from tuner.records import RunError
    from tuner.safe_io import read_text, regular

    p = Path(run_dir) / "history.csv"
    if not regular(p):
        raise RunError(f"{p}: missing (nothing evaluated yet?)")
    try:
        df = pd.read_csv(io.StringIO(read_text(p)), keep_default_na=False, na_values=[""])
    except (pd.errors.ParserError, pd.errors.EmptyDataError, UnicodeDecodeError) as exc:
        raise RunError(f"{p}: unreadable: {str(exc).strip()}") from None
    missing = [c for c in ("eval", "stage", "generation", "fitness", "status") if c not in df.columns]
    if missing:
        raise RunError(f"{p}: missing columns {missing}")
    return df


def convergence_table(hist: pd.DataFrame) -> pd.DataFrame:
    """Per generation: best of the generation, median, best so far and evaluations so far."""
    ok = hist[hist["status"] == "ok"]
    g = ok.groupby(["stage", "generation"])["fitness"]
    df = pd.DataFrame({"gen_best": g.min(), "gen_median": g.median()}).reset_index()
    evals = hist.groupby(["stage", "generation"])["eval"].max().reset_index()
    df = df.merge(evals, on=["stage", "generation"], how="right").sort_values("eval")
    df["best"] = df["gen_best"].cummin()
    df["n_evals"] = df["eval"] + 1
    return df


def plot_convergence(run_dir: Path, path: Path | None = None) -> Path:
    """Best-so-far and generation median fitness against evaluations (``figures/convergence.png``)."""
    plt = pyplot()
    run_dir = Path(run_dir)
    conv = convergence_table(load_history(run_dir))
    fig, ax = plt.subplots(figsize=(WIDTH_IN, 3.8))
    ax.plot(conv["n_evals"], conv["best"], label="best so far", lw=2)
    ax.plot(conv["n_evals"], conv["gen_median"], label="generation median", lw=1, alpha=0.7)
    _log_y_if_wide(ax, conv[["best", "gen_median"]].to_numpy().ravel())
    for s in sorted(conv["stage"].unique())[1:]:
        ax.axvline(conv[conv["stage"] == s]["n_evals"].min(), color="grey", ls=":", lw=1)
    ax.set_xlabel("evaluations")
    ax.set_ylabel("fitness")
    ax.set_title(f"convergence of {run_dir.name}")
    ax.grid(alpha=0.3)
    ax.legend()
    fig.tight_layout()
    return _save(fig, path or run_dir / "figures" / "convergence.png")


def _grid(n: int, ncol_max: int = 3, row_in: float = 3.0):
    plt = pyplot()
    ncol = min(ncol_max, max(n, 1))
    nrow = int(np.ceil(n / ncol))
    h = row_in * nrow + 0.6
    fig, axes = plt.subplots(nrow, ncol, figsize=(WIDTH_IN, h), squeeze=False)
    # fixed margins (inches): constrained layout costs seconds per figure with a dozen log axes
    fig.subplots_adjust(left=0.08, right=0.9, bottom=0.62 / h, top=1 - 0.45 / h, wspace=0.28, hspace=0.75 / row_in)
    for ax in axes.ravel()[n:]:
        ax.set_visible(False)
    return fig, axes.ravel()[:n]


def fitness_vs_params_figure(hist: pd.DataFrame, space: Space, best: dict[str, Any] | None = None):
    """The figure of :func:`plot_fitness_vs_params` (returned for inspection; the caller saves or closes it)."""
    ok = hist[hist["status"] == "ok"]
    n_failed = int((hist["status"] != "ok").sum())
    params = [p for p in space.free if p.name in hist.columns]
    fig, axes = _grid(len(params))
    fit = ok["fitness"].astype(float).to_numpy()
    gen = (ok["stage"] * 10_000 + ok["generation"]).to_numpy()
    for i, (ax, p) in enumerate(zip(axes, params)):
        x = ok[p.name].astype(float).to_numpy()
        sc = ax.scatter(x, fit, c=gen, s=14, cmap="viridis", alpha=0.75, lw=0)
        if p.scale == "log":
            ax.set_xscale("log")
            _plain_log_labels(ax.xaxis)
        for b in (p.low, p.high):
            ax.axvline(b, color="tab:red", ls="--", lw=1)
        if best and p.name in best and len(ok):
            bf = float(ok["fitness"].min()) if len(ok) else np.nan
            ax.scatter([float(best[p.name])], [bf], marker="*", s=180, color="tab:red", edgecolor="k", zorder=5,
                       label="best")
        _log_y_if_wide(ax, fit)
        pad = 0.04
        if p.scale == "log":
            lo, hi = np.log10(p.low), np.log10(p.high)
            ax.set_xlim(10 ** (lo - pad * (hi - lo)), 10 ** (hi + pad * (hi - lo)))
        else:
            ax.set_xlim(p.low - pad * (p.high - p.low), p.high + pad * (p.high - p.low))
        ax.set_xlabel(f"{p.name} ({p.unit})" if p.unit else p.name)
        if i % 3 == 0:
            ax.set_ylabel("fitness")
        ax.grid(alpha=0.3)
    if len(params) and len(ok):
        axes[0].legend(loc="best")
        cax = fig.add_axes((0.92, 0.62 / fig.get_figheight(), 0.012, 1 - 1.07 / fig.get_figheight()))
        fig.colorbar(sc, cax=cax, label="generation (stage x 10000 + generation)" if ok["stage"].max() > 0
                     else "generation")
    fig.suptitle(f"fitness against each parameter (dashed: search bounds; {len(ok)} evaluations"
                 + (f", {n_failed} failed not shown)" if n_failed else ")"))
    return fig


def plot_fitness_vs_params(hist: pd.DataFrame, space: Space, best: dict[str, Any] | None, path: Path) -> Path:
    """Fitness of every successful evaluation against each free parameter, coloured by generation.

    Log x-axes for log-scaled parameters, the search bounds as dashed lines, the best marked by a star.
    """
    return _save(fitness_vs_params_figure(hist, space, best), path)


def parallel_coordinates_figure(hist: pd.DataFrame, space: Space, n_best: int = 30):
    """The figure of :func:`plot_parallel_coordinates`."""
    plt = pyplot()
    ok = hist[hist["status"] == "ok"].sort_values("fitness")
    params = [p for p in space.free if p.name in hist.columns]
    top = ok.head(n_best)
    fig, ax = plt.subplots(figsize=(WIDTH_IN, 4.2))
    xs = np.arange(len(params))
    if len(top) and params:
        u = np.array([[p.to_unit(float(v)) for p, v in zip(params, row)]
                      for row in top[[p.name for p in params]].to_numpy()])
        f = top["fitness"].astype(float).to_numpy()
        norm = plt.Normalize(f.min(), f.max() if f.max() > f.min() else f.min() + 1)
        cmap = plt.get_cmap("viridis_r")
        for row, fv in zip(u[::-1], f[::-1]):  # best drawn last, on top
            ax.plot(xs, row, color=cmap(norm(fv)), lw=1, alpha=0.7)
        ax.plot(xs, u[0], color="tab:red", lw=2.5, marker="o", label=f"best (fitness {f[0]:.4g})")
        sm = plt.cm.ScalarMappable(norm=norm, cmap=cmap)
        fig.colorbar(sm, ax=ax, label="fitness", pad=0.01)
        ax.legend(loc="upper right")
    for x in xs:
        ax.axvline(x, color="k", lw=0.8)
    ax.axhline(0, color="tab:red", ls="--", lw=1)
    ax.axhline(1, color="tab:red", ls="--", lw=1)
    ax.set_xticks(xs, [f"{p.name}\n[{p.low:.3g}, {p.high:.3g}]" + ("\nlog" if p.scale == "log" else "")
                       for p in params], fontsize=9)
    if len(params) > 8:
        ax.tick_params(axis="x", labelrotation=30)
    ax.set_ylim(-0.05, 1.05)
    ax.set_ylabel("position in bounds (0 = low, 1 = high)")
    ax.set_title(f"the {len(top)} best candidates in unit-cube coordinates (log parameters in log10)")
    ax.grid(alpha=0.3, axis="y")
    fig.tight_layout()
    return fig


def plot_parallel_coordinates(hist: pd.DataFrame, space: Space, path: Path, n_best: int = 30) -> Path:
    """The ``n_best`` best candidates as lines over one axis per parameter, in unit-cube coordinates."""
    return _save(parallel_coordinates_figure(hist, space, n_best), path)


# --- sweeps --------------------------------------------------------------------------------------
def _job_space(job_dir: Path) -> Space | None:
    from tuner.bounds import _run_space

    return _run_space(job_dir)


def best_params_unit_figure(sweep_dir: Path, done: pd.DataFrame):
    """Best parameters of every job in unit coordinates of its own bounds, one column per parameter."""
    plt = pyplot()
    methods = sorted(done["method"].unique())
    colors = {m: plt.cm.tab10(i % 10) for i, m in enumerate(methods)}
    names: list[str] = []
    labels: dict[str, str] = {}
    points = []
    for _, r in done.iterrows():
        space = _job_space(Path(sweep_dir) / "jobs" / r["job"])
        if space is None:
            continue
        for p in space.free:
            col = f"param.{p.name}"
            if col not in r or pd.isna(r[col]):
                continue
            if p.name not in names:
                names.append(p.name)
                labels[p.name] = f"{p.name}\n[{p.low:.3g}, {p.high:.3g}]" + ("\nlog" if p.scale == "log" else "")
            points.append((p.name, r["method"], p.to_unit(float(r[col]))))
    if not names:
        return None
    fig, ax = plt.subplots(figsize=(WIDTH_IN, 4.4))
    width = 0.6
    for i, m in enumerate(methods):
        off = (i - (len(methods) - 1) / 2) * width / max(len(methods), 1)
        pts = [(names.index(n), u) for n, mm, u in points if mm == m]
        if pts:
            x, u = np.array(pts).T
            ax.scatter(x + off, u, color=colors[m], s=40, label=m, edgecolor="k", lw=0.4, zorder=3)
    ax.axhline(0, color="tab:red", ls="--", lw=1)
    ax.axhline(1, color="tab:red", ls="--", lw=1)
    ax.set_xticks(range(len(names)), [labels[n] for n in names], fontsize=8)
    if len(names) > 8:
        ax.tick_params(axis="x", labelrotation=30)
    ax.set_ylim(-0.05, 1.05)
    ax.set_ylabel("position in bounds (0 = low, 1 = high)")
    ax.set_title("best parameters of every job (dashed: search bounds; log parameters in log10)")
    ax.grid(alpha=0.3, axis="y")
    ax.legend(fontsize=8, ncol=min(4, len(methods)), loc="upper center", bbox_to_anchor=(0.5, -0.28))
    fig.tight_layout()
    return fig


def responses_figure(sweep_dir: Path, done: pd.DataFrame):
    """Each method's best job (lowest fitness) through its objective's ``traces(params)`` hook, on shared axes.

    ``traces`` returns ``{panel label: {"t": (N,), "y": (N,), "ref": (N,) or None}}``; the figure has one
    panel per label and one line per method. ``None`` unless every job's objective rebuilds and has the
    hook (e.g. a closed-loop sweep: speed, yaw rate, IB angle and current).
    """
    from tuner.objective import hook
    from tuner.records import RunError
    from tuner.registry import build_objective
    from tuner.rundir import RunDir

    jobs = Path(sweep_dir) / "jobs"
    curves: dict[str, tuple[float, dict[str, Any]]] = {}
    for m in sorted(done["method"].unique()):
        job = done[done["method"] == m].sort_values("best_fitness")["job"].iloc[0]
        rd = RunDir(jobs / job)
        try:
            cfg, best = rd.config(), rd.best()
            if cfg["objective"].get("kind") == "python":  # a report never imports code a run directory names
                return None
            obj = build_objective(dict(cfg["objective"]), Path(cfg.get("base_dir", rd.path)))
        except (RunError, ValueError, OSError, ImportError, KeyError, AttributeError):
            return None
        fn = hook(obj, "traces")
        if fn is None:
            return None
        curves[m] = (best.fitness, dict(fn(dict(best.params))))
    if not curves:
        return None
    labels = list(next(iter(curves.values()))[1])
    plt = pyplot()
    colors = {m: plt.cm.tab10(i % 10) for i, m in enumerate(curves)}
    fig, axes = plt.subplots(len(labels), 1, figsize=(WIDTH_IN, 2.1 * len(labels) + 0.6), sharex=True, squeeze=False)
    axes = axes[:, 0]
    ref_drawn = set()
    for m, (fitness, tr) in curves.items():
        for ax, name in zip(axes, labels):
            c = tr.get(name)
            if c is None:
                continue
            t, y = np.asarray(c["t"]), np.asarray(c["y"])
            n = min(len(t), len(y))
            ax.plot(t[:n], y[:n], color=colors[m], lw=1.1, label=f"{m} (best {fitness:.4g})")
            ref = c.get("ref")
            if ref is not None and name not in ref_drawn:
                ref = np.asarray(ref)
                k = min(len(t), len(ref))
                ax.plot(t[:k], ref[:k], "k:", lw=1.2, label="reference")
                ref_drawn.add(name)
            ax.set_ylabel(name)
            ax.grid(alpha=0.3)
    axes[0].legend(fontsize=8, ncol=2, loc="lower left", bbox_to_anchor=(0.0, 1.02), borderaxespad=0)
    axes[-1].set_xlabel("time (s)")
    fig.suptitle("response of the best job of each method", y=0.995)
    fig.tight_layout()
    return fig


def sweep_figures(sweep_dir: Path, df: pd.DataFrame) -> list[tuple[str, Path]]:
    """Sweep figures: convergence of every job, final fitness per method (box and points), per-axis errors
    per method (filter objectives), best parameters of every job in unit coordinates."""
    plt = pyplot()
    figs_dir = Path(sweep_dir) / "figures"
    from tuner.safe_io import check_not_link

    check_not_link(figs_dir)
    figs_dir.mkdir(parents=True, exist_ok=True)
    out: list[tuple[str, Path]] = []
    done = df[df["status"] == "finished"] if len(df) else df
    if len(done) == 0 or "best_fitness" not in done:
        return out
    methods = sorted(done["method"].unique())
    colors = {m: plt.cm.tab10(i % 10) for i, m in enumerate(methods)}

    fig, ax = plt.subplots(figsize=(WIDTH_IN, 4))
    for _, r in done.iterrows():
        c = convergence_table(load_history(Path(sweep_dir) / "jobs" / r["job"]))
        ax.plot(c["n_evals"], c["best"], color=colors[r["method"]], alpha=0.8, lw=1.2, label=r["method"])
    handles, labels = ax.get_legend_handles_labels()
    uniq = dict(zip(labels, handles))
    ax.legend(uniq.values(), uniq.keys(), fontsize=8)
    _log_y_if_wide(ax, done["best_fitness"].astype(float).to_numpy())
    ax.set_xlabel("evaluations")
    ax.set_ylabel("best fitness so far")
    ax.grid(alpha=0.3)
    fig.tight_layout()
    out.append(("Convergence of every job", _save(fig, figs_dir / "convergence_all.png")))

    col = "test_fitness" if "test_fitness" in done and done["test_fitness"].notna().any() else "best_fitness"
    fig, ax = plt.subplots(figsize=(WIDTH_IN, 3.8))
    data = [done[done["method"] == m][col].astype(float).dropna().to_numpy() for m in methods]
    ax.boxplot(data, tick_labels=methods, showmeans=True)
    rng = np.random.default_rng(0)  # fixed jitter: the figure is a function of the results
    for i, d in enumerate(data):
        ax.scatter(i + 1 + rng.uniform(-0.08, 0.08, len(d)), d, s=16, color=colors[methods[i]], edgecolor="k",
                   lw=0.4, zorder=3)
    _log_y_if_wide(ax, np.concatenate(data) if data else np.array([]))
    ax.set_ylabel(col.replace("_", " "))
    ax.tick_params(axis="x", labelrotation=15 if len(methods) > 4 else 0, labelsize=9)
    ax.grid(alpha=0.3, axis="y")
    fig.tight_layout()
    out.append((f"Final {col.replace('_', ' ')} per method over seeds", _save(fig, figs_dir / "final_fitness_box.png")))

    split = "test" if any(c.startswith("test.") for c in done.columns) else "train"
    axes_cols = [f"{split}.{a}_rmse_deg" for a in ("roll", "pitch", "yaw", "total")]
    axes_cols = [c for c in axes_cols if c in done.columns and done[c].notna().any()]
    if axes_cols:
        fig, ax = plt.subplots(figsize=(WIDTH_IN, 3.8))
        w = 0.8 / len(methods)
        for i, m in enumerate(methods):
            sub = done[done["method"] == m]
            med = [float(sub[c].astype(float).median()) for c in axes_cols]
            x = np.arange(len(axes_cols)) + (i - (len(methods) - 1) / 2) * w
            ax.bar(x, med, width=w, color=colors[m], label=m, alpha=0.85)
            for j, c in enumerate(axes_cols):
                v = sub[c].astype(float).dropna().to_numpy()
                ax.scatter(np.full(len(v), x[j]), v, s=10, color="k", zorder=3)
        ax.set_xticks(range(len(axes_cols)), [c.split(".", 1)[1].replace("_rmse_deg", "") for c in axes_cols])
        ax.set_ylabel(f"{split} RMSE (deg), median and seeds")
        ax.set_title(f"attitude errors per method on the {split} recordings")
        ax.legend(fontsize=8)
        ax.grid(alpha=0.3, axis="y")
        fig.tight_layout()
        out.append((f"{split.capitalize()} errors per axis and method", _save(fig, figs_dir / "errors_by_method.png")))

    fig = responses_figure(Path(sweep_dir), done)
    if fig is not None:
        out.append(("Responses of each method's best job", _save(fig, figs_dir / "responses.png")))
    fig = best_params_unit_figure(Path(sweep_dir), done)
    if fig is not None:
        out.append(("Best parameters of every job within their bounds", _save(fig, figs_dir / "best_parameters.png")))
    return out
