"""The sweep report's score-against-swept-value plot (tuner/plots/swept.py): a sweep over a PID's Ms limit (the
IAE-Ms trade-off) draws one point per job at its grid value and score, the medians over seeds joined, in the PNG
and the interactive page alike; a sweep without a numeric grid of at least three values draws none."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
import yaml

from tuner.plots import swept
from tuner.plots.context import SweepContext
from tuner.sweep import collect, run_sweep

JOB = {"name": "pi", "seed": 1,
       "objective": {"kind": "closed_loop", "plant": {"tf": {"num": [1.0], "den": [1.0, 2.0, 1.0]}},
                     "controller": "pid2dof", "period_s": 0.05, "fixed": {"Td_s": 0.0},
                     "scenario": {"duration_s": 8.0, "reference": [], "load": [{"t": 0.0, "value": 1.0}]},
                     "cost": {"iae": 1.0}, "requirements": {"max_ms": 1.4}},
       "parameters": {"K": {"low": 0.1, "high": 10.0, "scale": "log"},
                      "Ti_s": {"low": 0.2, "high": 20.0, "scale": "log"}},
       "optimizer": {"method": "pso", "population": 6, "generations": 4}, "parallel": {"backend": "serial"}}


def _sweep(tmp_path, grid, seeds=(1, 2)):
    doc = {"sweep": {"name": "tradeoff", "base": JOB, "grid": grid, "seeds": list(seeds)}}
    (tmp_path / "s.yaml").write_text(yaml.safe_dump(doc, sort_keys=False))
    out = run_sweep(tmp_path / "s.yaml", sweep_dir=tmp_path / "sw", quiet=True)
    assert out["ok"], out
    return tmp_path / "sw"


@pytest.mark.slow
def test_score_against_the_swept_ms_limit(tmp_path):
    limits = [1.2, 1.5, 2.0]
    sw = _sweep(tmp_path, {"objective.requirements.max_ms": limits})
    df = collect(sw)
    assert sorted(df["grid.objective.requirements.max_ms"]) == sorted(limits * 2)
    d = swept.data(SweepContext(sw, df))
    assert d["key"] == "objective.requirements.max_ms" and d["score"] == "best_fitness"
    (s,) = d["series"]
    assert s["mx"] == limits
    for x, y in zip(s["x"], s["y"]):  # every job at its own grid value and score
        row = df[(df["grid.objective.requirements.max_ms"] == x) & (df["best_fitness"] == y)]
        assert len(row) == 1
    for x, m in zip(s["mx"], s["my"]):
        assert m == pytest.approx(np.median(df[df["grid.objective.requirements.max_ms"] == x]["best_fitness"]))
    assert s["my"][-1] < s["my"][0]  # a looser robustness limit lets the load IAE fall
    md = (sw / "report.md").read_text()
    assert "score_vs_swept.png" in md and (sw / "figures" / "score_vs_swept.png").stat().st_size > 1000
    html = (sw / "report.html").read_text() if (sw / "report.html").exists() else ""
    if "Plotly" in html or "plotly" in html:
        assert '"swept"' in html


def test_no_curve_without_a_numeric_grid_of_three_values(tmp_path):
    jobs = pd.DataFrame({"job": ["a", "b"], "method": ["m", "m"], "status": ["finished"] * 2,
                         "best_fitness": [1.0, 2.0], "grid.x": [1.0, 2.0]})
    assert swept.data(SweepContext(tmp_path, jobs)) is None
    jobs = pd.DataFrame({"job": list("abc"), "method": ["m"] * 3, "variant": ["m"] * 3, "status": ["finished"] * 3,
                         "best_fitness": [3.0, 2.0, 1.0], "grid.x": [1.0, 2.0, 3.0], "grid.y": [0.0, 0.0, 1.0]})
    d = swept.data(SweepContext(tmp_path, jobs))
    assert d["key"] == "x" and [s["name"] for s in d["series"]] == ["m, y=0.0", "m, y=1.0"]
    assert d["series"][0]["mx"] == [1.0, 2.0] and d["series"][1]["y"] == [1.0]
