"""Report figures (log axes, bounds, best marked, unit-cube coordinates) and the recording x metric pivot."""

import math

import numpy as np
import pandas as pd
import pytest

from tuner.figures import fitness_vs_params_figure, parallel_coordinates_figure
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


def test_fitness_vs_params_axes_scales_bounds_and_best():
    import matplotlib.pyplot as plt

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
    plt.close(fig)


def test_parallel_coordinates_in_unit_cube_with_best_on_top():
    import matplotlib.pyplot as plt

    hist = _hist()
    fig = parallel_coordinates_figure(hist, SPACE, n_best=10)
    ax = fig.axes[0]
    lines = [ln for ln in ax.get_lines() if len(ln.get_xdata()) == 2 and ln.get_label() != "_nolegend_"]
    best_line = next(ln for ln in lines if ln.get_label().startswith("best"))
    ok = hist[hist["status"] == "ok"].sort_values("fitness")
    b = ok.iloc[0]
    np.testing.assert_allclose(best_line.get_ydata(), [(math.log10(b["beta"]) + 3) / 3, b["kp"] / 10])
    candidate_lines = [ln for ln in ax.get_lines() if len(np.unique(ln.get_xdata())) == 2 and ln.get_linestyle() == "-"]
    ys = np.concatenate([ln.get_ydata() for ln in candidate_lines])
    assert ys.min() >= 0 and ys.max() <= 1 and len(candidate_lines) == 11  # 10 best + the highlighted best
    assert [t.get_text().split("\n")[0] for t in ax.get_xticklabels()] == ["beta", "kp"]
    plt.close(fig)


def test_pivot_of_flattened_metric_keys():
    df = pivot_metrics({"rec/trial A/rmse_deg": 1.0, "rec/trial A/mae_deg": 2.0, "rec/B/rmse_deg": 3.0,
                        "walk-1.rmse_deg": 4.0, "fitness_extra": 5.0, "note": "text", "flag": True})
    assert sorted(df.index) == ["-", "B", "trial A", "walk-1"]
    assert df.loc["trial A", "mae_deg"] == 2.0 and df.loc["walk-1", "rmse_deg"] == 4.0
    assert math.isnan(df.loc["B", "mae_deg"]) and df.loc["-", "fitness_extra"] == 5.0
    assert "note" not in df.columns and "flag" not in df.columns


@pytest.mark.parametrize("fn", [fitness_vs_params_figure, parallel_coordinates_figure])
def test_figures_with_only_failures_do_not_raise(fn):
    import matplotlib.pyplot as plt

    hist = _hist()
    hist["status"] = "failed"
    fig = fn(hist, SPACE) if fn is parallel_coordinates_figure else fn(hist, SPACE, None)
    plt.close(fig)


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


def test_pyplot_is_headless_and_silences_font_cache_noise():
    import logging

    import matplotlib

    from tuner.figures import pyplot

    pyplot()
    assert matplotlib.get_backend().lower() == "agg"
    # "findfont: Font family ... not found" is logged at WARNING while a fresh environment builds its font cache
    assert not logging.getLogger("matplotlib.font_manager").isEnabledFor(logging.WARNING)
