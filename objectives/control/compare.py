"""Controller comparison across the runs of a closed-loop sweep (thesis section 2.3.4, Fig. 2.18).

Every closed-loop run leaves ``best.yaml`` (best parameters, F, metrics, and the ``evaluation`` block
of :meth:`ClosedLoopObjective.finalize`) and ``response_best.npz`` (the tuned closed loop). This
module puts the runs of a sweep side by side: one table with F, the peak IB angle, the peak average
current and the rise times per controller, and one figure with every tuned response (speed, yaw
rate, IB angle, average current), like the thesis's Fig. 2.18 for fuzzy vs PID.

    python -m objectives.control.compare runs/sweeps/wmp-compare

writes ``controllers.md`` and ``figures/responses.png`` into the sweep directory.
"""

from __future__ import annotations

import argparse
import math
import pathlib
from dataclasses import dataclass

import numpy as np
import yaml

from objectives.control.report import save_figure

__all__ = ["ControllerResult", "collect_runs", "comparison_table", "plot_responses", "write_comparison"]


@dataclass(frozen=True)
class ControllerResult:
    """One tuned controller of a sweep.

    Attributes
    ----------
    job : run directory name inside ``jobs/``.
    controller : controller name (``pid``, ``protective_fuzzy``, ...).
    fitness, initial_fitness : F of eq. 2.39 at the tuned and the initial parameters (NaN when the
        initial parameters fail, e.g. violate a tracking requirement: see ``initial_error``).
    peak_theta3_deg, peak_current_A : peak |IB angle| (deg) and peak |average current| (A), tuned.
    rise_time_nu_s, rise_time_xi_s : 0-90 % rise times of the first speed and yaw steps (s), tuned.
    response : path of ``response_best.npz`` (``None`` if the run has none).
    settle_theta3_s : time until the IB angle stays within 5 deg after the first speed step (s, Table
        2.4's T_5deg), tuned; NaN for runs stored before the metric existed.
    """

    job: str
    controller: str
    fitness: float
    initial_fitness: float
    peak_theta3_deg: float
    peak_current_A: float
    rise_time_nu_s: float
    rise_time_xi_s: float
    response: pathlib.Path | None
    initial_error: str = ""
    settle_theta3_s: float = math.nan


def collect_runs(sweep_dir: str | pathlib.Path) -> list[ControllerResult]:
    """The finished closed-loop runs under ``sweep_dir/jobs`` (or ``sweep_dir`` itself if it is a run)."""
    root = pathlib.Path(sweep_dir)
    dirs = sorted(p for p in (root / "jobs").iterdir() if p.is_dir()) if (root / "jobs").is_dir() else [root]
    out = []
    for d in dirs:
        best = d / "best.yaml"
        if not best.exists():
            continue
        doc = yaml.safe_load(best.read_text()) or {}
        m = doc.get("metrics") or {}
        ev = doc.get("evaluation") or {}
        cfg = yaml.safe_load((d / "config.yaml").read_text()) if (d / "config.yaml").exists() else {}
        controller = ((cfg or {}).get("objective") or {}).get("controller", d.name)
        npz = d / "response_best.npz"
        out.append(
            ControllerResult(
                job=d.name,
                controller=str(controller),
                fitness=float(doc.get("fitness", math.nan)),
                initial_fitness=float(ev.get("initial_fitness", math.nan))
                if ev.get("initial_status", "ok") == "ok"
                else math.nan,
                peak_theta3_deg=float(m.get("peak_theta3_deg", math.nan)),
                peak_current_A=float(m.get("peak_current_A", math.nan)),
                rise_time_nu_s=float(m.get("rise_time_nu_s", math.nan)),
                rise_time_xi_s=float(m.get("rise_time_xi_s", math.nan)),
                response=npz if npz.exists() else None,
                initial_error=str(ev.get("initial_error", "")),
                settle_theta3_s=float(m.get("settle_theta3_s", math.nan)),
            )
        )
    return out


def comparison_table(results: list[ControllerResult]) -> str:
    """Markdown table, best F first."""
    head = (
        "| controller | F tuned | F initial | improvement % | peak IB angle (deg) | peak current (A) "
        "| rise speed (s) | rise yaw rate (s) | IB settles (s) |\n|---|---|---|---|---|---|---|---|---|"
    )
    rows = []
    for r in sorted(results, key=lambda r: r.fitness):
        if r.initial_fitness > 0:
            init = f"{r.initial_fitness:.4f} | {100 * (r.initial_fitness - r.fitness) / r.initial_fitness:.1f}"
        else:
            init = f"failed: {r.initial_error or 'see the run'} | -"
        rows.append(
            f"| {r.controller} | {r.fitness:.4f} | {init} | {r.peak_theta3_deg:.1f} "
            f"| {r.peak_current_A:.3f} | {r.rise_time_nu_s:.2f} | {r.rise_time_xi_s:.2f} | {r.settle_theta3_s:.2f} |"
        )
    return "\n".join([head, *rows])


def plot_responses(results: list[ControllerResult], path: str | pathlib.Path) -> pathlib.Path:
    """Every tuned response on one figure: speed, yaw rate, IB angle, average current vs time."""
    from tuner.figures import pyplot

    plt = pyplot()
    fig, ax = plt.subplots(4, 1, figsize=(8, 9), sharex=True)
    ref_drawn = False
    for i, r in enumerate(sorted(results, key=lambda r: r.fitness)):
        if r.response is None:
            continue
        z = np.load(r.response)
        n = int(z["n_done"])
        t, y, ref = z["t"][:n], z["outputs"][:n], z["references"][:n]
        c = plt.cm.tab10(i % 10)
        ax[0].plot(t, y[:, 0], color=c, label=f"{r.controller} (F={r.fitness:.4f})")
        ax[1].plot(t, np.degrees(y[:, 3]), color=c)
        ax[2].plot(t, np.degrees(y[:, 1]), color=c)
        ax[3].plot(t, y[:, 4], color=c)
        if not ref_drawn:
            ax[0].plot(t, ref[:, 0], "k:", label="reference")
            ax[1].plot(t, np.degrees(ref[:, 1]), "k:")
            ref_drawn = True
    for a, lab in zip(ax, ["speed (m/s)", "yaw rate (deg/s)", "IB angle theta3 (deg)", "avg. current I_A (A)"]):
        a.set_ylabel(lab)
        a.grid(True, alpha=0.3)
    ax[0].legend(loc="upper right", fontsize=8)
    ax[-1].set_xlabel("time (s)")
    ax[0].set_title("Tuned controllers on the WMP (thesis Fig. 2.18)")
    return save_figure(fig, path)


def write_comparison(sweep_dir: str | pathlib.Path) -> pathlib.Path:
    """``controllers.md`` (table + figure) and ``figures/responses.png`` in ``sweep_dir``."""
    sweep_dir = pathlib.Path(sweep_dir)
    results = collect_runs(sweep_dir)
    if not results:
        raise ValueError(f"{sweep_dir}: no finished closed-loop run (no jobs/*/best.yaml)")
    fig = plot_responses(results, sweep_dir / "figures" / "responses.png")
    text = "\n".join(
        [
            "# Tuned controllers side by side",
            "",
            comparison_table(results),
            "",
            f"![responses]({fig.relative_to(sweep_dir).as_posix()})",
            "",
        ]
    )
    out = sweep_dir / "controllers.md"
    out.write_text(text)
    return out


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("sweep_dir", help="a closed-loop sweep directory (or one run directory)")
    print(write_comparison(ap.parse_args(argv).sweep_dir))


if __name__ == "__main__":
    main()
