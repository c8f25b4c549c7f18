"""A sweep ranks by CV when validation ran, else by test, else by train score, says which, and gives each
method a defaults row scored the same way; ``tuner show``/``compare`` print the CV result, the gap, the
fixed settings and what was tuned."""

from __future__ import annotations

import math
import re
import shutil
from pathlib import Path

import pandas as pd
import pytest
import yaml

from objectives.attitude.objective import FilterObjective
from tuner.cli import main
from tuner.rundir import RunDir
from tuner.sweep import collect, ranked_by, run_sweep, summarize

ROOT = Path(__file__).resolve().parents[2]
TINY = {"optimizer.population": 4, "optimizer.generations": 1, "parallel": {"backend": "serial"},
        "objective.data": {"train": [{"synthetic": {"generator": "bench6dof", "duration_s": 5, "rate_hz": 200,
                                                    "seed": s}} for s in (1, 2)],
                           "test": [{"synthetic": {"generator": "bench6dof", "duration_s": 5, "rate_hz": 200,
                                                   "seed": 101}}]}}


def _df(rows):
    base = {"status": "finished", "seed": 1}
    return pd.DataFrame([{**base, **r} for r in rows])


def test_ranking_follows_validation_then_test_then_train():
    rows = [{"method": "a", "best_fitness": 1.0, "test_fitness": 3.0, "cv_fitness": 5.0, "defaults_fitness": 2.0,
             "defaults_test_fitness": 2.5, "defaults_cv_fitness": 4.0},
            {"method": "b", "best_fitness": 2.0, "test_fitness": 2.0, "cv_fitness": 4.5, "defaults_fitness": 9.0,
             "defaults_test_fitness": 9.0, "defaults_cv_fitness": 9.0}]
    s = summarize(_df(rows))
    assert ranked_by(_df(rows))[0] == "cv_fitness"
    # CV: b (4.5) < a's defaults (4.0)? no: a's defaults 4.0 first, then b 4.5, a 5.0, b's defaults 9.0
    assert list(s.index) == ["a (defaults)", "b", "a", "b (defaults)"]
    assert list(s[("kind", "")]) == ["defaults", "tuned", "tuned", "defaults"]
    assert set(s[("ranked_by", "")]) == {"cv_fitness"}
    assert s.loc["a (defaults)", ("cv_fitness", "median")] == 4.0
    assert math.isnan(s.loc["a (defaults)", ("best_fitness", "median")])  # only the ranked score is filled
    no_cv = [{k: v for k, v in r.items() if "cv" not in k} for r in rows]
    no_cv[1]["cv_fitness"] = 1.0  # CV in one job only: not every job validated, so test ranks
    s = summarize(_df(no_cv))
    assert s.attrs["ranked_by"][0] == "test_fitness"
    assert list(s.index) == ["b", "a (defaults)", "a", "b (defaults)"]
    train = [{k: v for k, v in r.items() if "cv" not in k and "test" not in k} for r in rows]
    s = summarize(_df(train))
    assert s.attrs["ranked_by"][0] == "best_fitness" and "train score" in s.attrs["ranked_by"][1]
    assert list(s.index) == ["a", "b", "a (defaults)", "b (defaults)"]


def _demo_sweep(tmp_path, validation=None):
    for f in ("demo.yaml", "ekf_bench6dof.yaml", "faekf_bench6dof.yaml"):
        shutil.copy(ROOT / "configs" / f, tmp_path / f)
    doc = yaml.safe_load((tmp_path / "demo.yaml").read_text())
    for over in doc["sweep"]["variants"].values():
        over.update(TINY)
        if validation:
            over["validation"] = validation
    (tmp_path / "demo.yaml").write_text(yaml.safe_dump(doc, sort_keys=False))
    out = run_sweep(tmp_path / "demo.yaml", sweep_dir=tmp_path / "sw", quiet=True)
    assert out["ok"], out
    return tmp_path / "sw"


def _defaults_score(job_dir: Path, which: str) -> float:
    raw = RunDir(job_dir).config()
    o = raw["objective"]
    obj = FilterObjective(o["filter"], o["data"]["train"], o["data"]["test"], dict(o.get("fixed") or {}),
                          o["metric"], dict(o.get("metric_options") or {}), warmup_s=o["warmup_s"])
    return obj.score(obj.default_params(), which).fitness


@pytest.mark.slow
def test_demo_sweep_ranks_by_test_score_with_defaults_rows(tmp_path):
    sw = _demo_sweep(tmp_path)
    s = pd.read_csv(sw / "summary.csv", index_col=0)
    assert set(s["ranked_by"]) == {"test_fitness"}
    assert sorted(s.index) == ["ekf", "ekf (defaults)", "faekf", "faekf (defaults)"]
    med = s["test_fitness.median"]
    assert list(med) == sorted(med) and list(s["rank"]) == [1, 2, 3, 4]
    df = collect(sw)
    for _, r in df.iterrows():  # the defaults row: the objective's defaults (with fixed values) on the test data
        assert r["defaults_test_fitness"] == pytest.approx(_defaults_score(sw / "jobs" / r["job"], "test"), rel=1e-9)
        assert med[f"{r['method']} (defaults)"] == pytest.approx(r["defaults_test_fitness"])
        assert med[r["method"]] == pytest.approx(r["test_fitness"])
    md = (sw / "report.md").read_text()
    assert "Ranked by the median test score" in md and "ekf (defaults)" in md
    from tuner.sweep import show_sweep

    shown = show_sweep(sw)
    assert "ranking by the median test score" in shown
    assert [ln.split(". ", 1)[1].split(":")[0] for ln in shown.splitlines() if ln.startswith("  ") and ". " in ln] \
        == list(s.index)


@pytest.mark.slow
def test_demo_sweep_with_validation_ranks_by_cv(tmp_path, capsys):
    sw = _demo_sweep(tmp_path, {"cv": "kfold", "folds": 2})
    s = pd.read_csv(sw / "summary.csv", index_col=0)
    assert set(s["ranked_by"]) == {"cv_fitness"}
    med = s["cv_fitness.median"]
    assert list(med) == sorted(med) and sorted(s.index) == ["ekf", "ekf (defaults)", "faekf", "faekf (defaults)"]
    for _, r in collect(sw).iterrows():
        val = RunDir(sw / "jobs" / r["job"]).validation()["cv"]
        assert med[f"{r['method']} (defaults)"] == pytest.approx(val["defaults_cv_score"])
        assert med[r["method"]] == pytest.approx(val["cv_score"])
    assert "Ranked by the median CV score" in (sw / "report.md").read_text()
    # show and compare: CV score, gap, fixed settings, the filter's name
    ekf, faekf = (sw / "jobs" / j for j in sorted(p.name for p in (sw / "jobs").iterdir() if p.is_dir()))
    assert main(["show", str(faekf)]) == 0
    out = capsys.readouterr().out
    val = RunDir(faekf).validation()["cv"]
    assert "tuned:      filter faekf" in out
    searched, fixed = out.split("searched:\n")[1].split("fixed:\n")
    assert re.search(r"^  window +400$", fixed, re.M) and re.search(r"^  fft_length +512$", fixed, re.M)
    assert re.search(r"^  q_q +\S+$", searched, re.M) and "window" not in searched
    assert f"cv:         {val['cv_score']:.6g}" in out and f"gap {val['gap']:+.3g}" in out
    assert main(["compare", str(ekf), str(faekf)]) == 0
    out = capsys.readouterr().out
    for line in ("tuned", "cv_fitness", "cv_gap", "fixed.window", "defaults_cv_fitness"):
        assert line in out, line
    assert "faekf" in out.split("tuned")[1].splitlines()[0]
