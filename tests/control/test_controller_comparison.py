"""The controller comparison of a closed-loop sweep (thesis 2.3.4, Fig. 2.18) comes from the engine's sweep
report: its per-job table of the objective's evaluation, each method's defaults row, and the ``traces``
figure of every method's best job. Checked against the closed loop re-simulated here."""

from __future__ import annotations

import math
import pathlib

import numpy as np
import pandas as pd
import pytest
import yaml

CONFIGS = pathlib.Path(__file__).parents[2] / "configs"


@pytest.fixture(scope="module")
def sweep(tmp_path_factory):
    from tuner.sweep import run_sweep

    d = tmp_path_factory.mktemp("compare")
    budget = {"optimizer.population": 4, "optimizer.generations": 2, "parallel.backend": "serial"}
    spec = {"sweep": {"name": "compare-smoke", "base": str(CONFIGS / "wmp_pid.yaml"),
                      "variants": {"pid": {"name": "cmp-pid", **budget},
                                   "fuzzy": {"base": str(CONFIGS / "wmp_fuzzy_protective.yaml"), "name": "cmp-fuzzy",
                                             **budget}},
                      "seeds": [1]}}
    path = d / "sweep.yaml"
    path.write_text(yaml.safe_dump(spec))
    out = run_sweep(path, d / "out", jobs=1, quiet=True)
    assert out["ok"], out["results"]
    return d / "out"


def _objective(job_dir: pathlib.Path):
    from objectives.control.objective import ClosedLoopObjective

    cfg = yaml.safe_load((job_dir / "config.yaml").read_text())
    return ClosedLoopObjective.from_config(cfg["objective"], CONFIGS)


@pytest.mark.slow
def test_sweep_table_has_every_controllers_tuned_and_initial_scores(sweep):
    df = pd.read_csv(sweep / "results.csv")
    assert sorted(df["method"]) == ["fuzzy", "pid"]
    for _, row in df.iterrows():
        job = sweep / "jobs" / row["job"]
        best = yaml.safe_load((job / "best.yaml").read_text())
        obj = _objective(job)
        ev = obj(best["params"])  # the tuned closed loop, simulated again
        assert row["train.F"] == pytest.approx(ev.fitness, rel=1e-9) == pytest.approx(row["best_fitness"], rel=1e-9)
        for k in ("peak_theta3_deg", "peak_current_A", "rise_time_nu_s", "rise_time_xi_s", "settle_theta3_s"):
            assert row[f"train.{k}"] == pytest.approx(ev.metrics[k], rel=1e-9, nan_ok=True)
        init = obj(obj.defaults)  # the thesis's "F initial": the controller's initial parameters
        want = init.fitness if init.status == "ok" else math.inf
        assert row["defaults_fitness"] == pytest.approx(want, rel=1e-9)
    report = (sweep / "report.md").read_text()
    assert "## Scores of the best parameters" in report and "train.peak_current_A" in report
    assert "pid (defaults)" in report and "fuzzy (defaults)" in report


@pytest.mark.slow
def test_responses_figure_overlays_each_controllers_best_tuned_loop(sweep):
    from tuner.plots import responses
    from tuner.plots.context import SweepContext

    assert (sweep / "figures" / "responses.png").read_bytes()[:4] == b"\x89PNG"
    df = pd.read_csv(sweep / "results.csv")
    fig = responses.figure(responses.data(SweepContext(sweep, df)))
    axes = fig.axes
    assert [a.get_ylabel() for a in axes] == ["speed (m/s)", "yaw rate (deg/s)", "IB angle theta3 (deg)",
                                             "avg. current (A)"]
    lines = {ln.get_label().split(" (")[0]: ln for ln in axes[0].get_lines()}
    assert set(lines) == {"fuzzy", "pid", "reference"}
    for m in ("fuzzy", "pid"):
        job = sweep / "jobs" / df[df["method"] == m].sort_values("best_fitness")["job"].iloc[0]
        sim = _objective(job).simulate(yaml.safe_load((job / "best.yaml").read_text())["params"])
        n = int(sim["n_done"])
        np.testing.assert_allclose(lines[m].get_ydata()[:n], np.asarray(sim["outputs"])[:n, 0], rtol=1e-12)
        cur = {ln.get_label().split(" (")[0]: ln for ln in axes[3].get_lines()}
        np.testing.assert_allclose(cur[m].get_ydata()[:n], np.asarray(sim["outputs"])[:n, 4], rtol=1e-12)
