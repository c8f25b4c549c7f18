"""Report plots (log axes, bounds, best marked, unit-cube coordinates; one data rule drawn as PNG and as the
interactive slot), the recording x metric pivot, and figures that leave matplotlib's global state alone."""

import math
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from tuner.plots import RUN_PLOTS, convergence, parcoords, slices
from tuner.plots.context import RunContext
from tuner.report import pivot_metrics
from tuner.space import Real, Space

SPACE = Space([Real("beta", 1e-3, 1.0, "log"), Real("kp", 0.0, 10.0), Real("variant", fixed="paper")])


def _hist(n=40, seed=0):
    rng = np.random.default_rng(seed)
    beta = 10 ** rng.uniform(-3, 0, n)
    kp = rng.uniform(0, 10, n)
    fit = (np.log10(beta) + 1.5) ** 2 + (kp - 3) ** 2 / 10 + 0.01
    status = np.where(np.arange(n) % 9 == 4, "failed", "ok")
    fit = np.where(status == "ok", fit, 1e12)
    return pd.DataFrame({"eval": range(n), "stage": 0, "generation": np.arange(n) // 8, "index": np.arange(n) % 8,
                         "beta": beta, "kp": kp, "variant": "paper", "fitness": fit, "status": status})


def _ctx(hist, best=None):
    return RunContext(Path("run"), hist, SPACE, dict(best or {}))


def fitness_vs_params_figure(hist, space, best=None):
    return slices.figure(slices.data(_ctx(hist, best)))


def test_fitness_vs_params_axes_scales_bounds_and_best():
    hist = _hist()
    ok = hist[hist["status"] == "ok"]
    best_row = ok.loc[ok["fitness"].idxmin()]
    fig = fitness_vs_params_figure(hist, SPACE, {"beta": best_row["beta"], "kp": best_row["kp"]})
    axes = [ax for ax in fig.axes if ax.get_xlabel()]
    assert [ax.get_xlabel() for ax in axes] == ["beta", "kp"]
    assert axes[0].get_xscale() == "log" and axes[1].get_xscale() == "linear"
    assert axes[0].get_yscale() == "log"  # failed evaluations (1e12) are left out, the rest spans > 20x
    for ax, (lo, hi) in zip(axes, [(1e-3, 1.0), (0.0, 10.0)]):
        vlines = sorted(ln.get_xdata()[0] for ln in ax.get_lines())
        assert vlines == [lo, hi]
        xmin, xmax = ax.get_xlim()
        assert xmin < lo and xmax > hi  # bounds visible
        pts = np.concatenate([c.get_offsets() for c in ax.collections])
        assert len(pts) == len(ok) + 1  # every successful evaluation and the star
        assert pts[:, 1].max() < 1e12
    star = axes[0].collections[-1].get_offsets()[0]
    assert star[0] == best_row["beta"] and star[1] == ok["fitness"].min()
    assert "4 failed not shown" in fig._suptitle.get_text()


def test_parallel_coordinates_in_unit_cube_with_best_on_top():
    hist = _hist()
    d = parcoords.data(_ctx(hist))
    fig = parcoords.figure(d)
    ax = fig.axes[0]
    lines = [ln for ln in ax.get_lines() if len(ln.get_xdata()) == 2 and ln.get_label() != "_nolegend_"]
    best_line = next(ln for ln in lines if ln.get_label().startswith("best"))
    ok = hist[hist["status"] == "ok"].sort_values("fitness")
    b = ok.iloc[0]
    np.testing.assert_allclose(best_line.get_ydata(), [(math.log10(b["beta"]) + 3) / 3, b["kp"] / 10], atol=1e-5)
    candidate_lines = [ln for ln in ax.get_lines() if len(np.unique(ln.get_xdata())) == 2 and ln.get_linestyle() == "-"]
    ys = np.concatenate([ln.get_ydata() for ln in candidate_lines])
    k = parcoords.n_best(len(ok))  # 35 successes: at least 20
    assert k == 20 and ys.min() >= 0 and ys.max() <= 1 and len(candidate_lines) == k + 1  # and the best again
    assert ax.get_lines()[len(candidate_lines) - 1] is best_line  # drawn last, on top
    assert [t.get_text().split("\n")[0] for t in ax.get_xticklabels()] == ["beta", "kp"]
    # the interactive slot draws exactly these candidates, best first
    slot = parcoords.slot(d)
    assert slot["fitness"] == ok["fitness"].head(k).tolist() and len(slot["u"]) == k
    drawn = sorted(tuple(np.round(ln.get_ydata(), 5)) for ln in candidate_lines[:-1])
    assert drawn == sorted(tuple(u) for u in slot["u"])


@pytest.mark.parametrize("n_ok, k", [(0, 0), (7, 7), (20, 20), (150, 20), (210, 21), (1000, 100), (1991, 200),
                                     (50_000, 200)])
def test_parallel_coordinates_draw_the_best_tenth_between_20_and_200(n_ok, k):
    assert parcoords.n_best(n_ok) == k


def test_pivot_of_flattened_metric_keys():
    df = pivot_metrics({"rec/trial A/rmse_deg": 1.0, "rec/trial A/mae_deg": 2.0, "rec/B/rmse_deg": 3.0,
                        "walk-1.rmse_deg": 4.0, "fitness_extra": 5.0, "note": "text", "flag": True})
    assert sorted(df.index) == ["-", "B", "trial A", "walk-1"]
    assert df.loc["trial A", "mae_deg"] == 2.0 and df.loc["walk-1", "rmse_deg"] == 4.0
    assert math.isnan(df.loc["B", "mae_deg"]) and df.loc["-", "fitness_extra"] == 5.0
    assert "note" not in df.columns and "flag" not in df.columns


@pytest.mark.parametrize("plot", RUN_PLOTS, ids=lambda p: p.NAME)
def test_plots_with_only_failures_draw_nothing_but_the_convergence(plot):
    hist = _hist()
    hist["status"] = "failed"
    d = plot.data(_ctx(hist))
    assert (d is None) == (plot is not convergence)
    if d is not None:
        plot.figure(d)


@pytest.mark.slow
def test_closed_loop_sweep_compares_responses_on_one_figure(tmp_path):
    from pathlib import Path

    import yaml
    from PIL import Image

    from tuner.sweep import run_sweep

    configs = Path(__file__).resolve().parents[2] / "configs"
    doc = {"sweep": {"name": "ctl", "base": str(configs / "wmp_pid.yaml"),
                     "variants": {"pid": {}, "lqr": {"base": str(configs / "wmp_lqr.yaml")}},
                     "grid": {"optimizer.population": [4], "optimizer.generations": [1],
                              "objective.requirements": [{}],  # a 4-candidate run need not meet them
                              "parallel.backend": ["serial"]}, "seeds": [1]}}
    (tmp_path / "ctl.yaml").write_text(yaml.safe_dump(doc))
    res = run_sweep(tmp_path / "ctl.yaml", sweep_dir=tmp_path / "sw", quiet=True)
    png = tmp_path / "sw" / "figures" / "responses.png"
    assert res["ok"] and png.exists()
    assert Image.open(png).size[0] == 1050  # drawn for the page width
    assert "responses.png" in (tmp_path / "sw" / "report.md").read_text()


@pytest.mark.slow
def test_a_run_with_its_report_leaves_the_backend_and_rc_params_as_they_were(tmp_path):
    """A notebook's inline backend and its settings survive ``tuner.tune()``: the engine's figures are Figure
    objects on their own canvas (a fresh interpreter: the backend is chosen once per process)."""
    prog = textwrap.dedent("""
        import sys
        import matplotlib
        try:
            import matplotlib_inline.backend_inline  # noqa: F401 - a notebook's backend, where installed
            backend = "module://matplotlib_inline.backend_inline"
        except ImportError:
            backend = "svg"  # any backend that is not Agg
        matplotlib.use(backend)
        matplotlib.rcParams["font.size"] = 13.0
        before = (matplotlib.get_backend(), dict(matplotlib.rcParams))
        import tuner
        job = {"name": "nb", "seed": 1, "objective": {"kind": "function", "function": "sphere", "dim": 3},
               "optimizer": {"method": "pso", "population": 8, "generations": 3},
               "parallel": {"backend": "serial"}, "output": sys.argv[1]}
        res = tuner.tune(job)
        assert (res.run_dir / "report.html").exists() and (res.run_dir / "figures" / "contour.png").exists()
        from tuner.figures import pyplot
        fig, ax = pyplot().subplots(2, 1, figsize=(4, 3), sharex=True)  # what the domain's figure code calls
        fig.savefig(sys.argv[1] + "/domain.png")
        after = (matplotlib.get_backend(), dict(matplotlib.rcParams))
        assert after[0] == before[0], after[0]
        changed = {k for k in before[1] if before[1][k] != after[1][k]}
        assert not changed, changed
        import matplotlib.pyplot as plt
        assert plt.get_fignums() == []  # no figure registered with pyplot (a notebook would show it)
        print("unchanged", backend)
    """)
    out = subprocess.run([sys.executable, "-c", prog, str(tmp_path)], capture_output=True, text=True, timeout=600,
                         cwd=tmp_path)
    assert out.returncode == 0 and "unchanged" in out.stdout, out.stderr[-3000:]
