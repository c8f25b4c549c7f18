"""``validation:``: CV after ``tuner run`` (and ``tuner cv RUN_DIR``) into the run directory, the gap in run
and sweep reports, and the final choice among the best candidates by a held-out fold."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest
import yaml

from objectives.attitude.objective import FilterObjective
from tests.tuner.kinds import kind_fixture
from tuner.cli import main
from tuner.config import ConfigError, ValidationConfig, config_from_dict
from tuner.run import run
from tuner.rundir import RunDir

SPECS = [{"synthetic": {"generator": "bench6dof", "duration_s": 4, "seed": s}} for s in (1, 2, 3, 4)]


def _raw(tmp_path, validation=None, **extra):
    raw = {"name": "valtest", "seed": 3, "output": str(tmp_path / "runs"),
           "objective": {"kind": "filter", "filter": "madgwick", "metric": "broad_mean_rmse", "data": SPECS},
           "optimizer": {"method": "pso", "population": 4, "generations": 2}, "parallel": {"backend": "serial"},
           **extra}
    if validation is not None:
        raw["validation"] = validation
    return raw


@pytest.mark.parametrize("section, key, what", [
    ({"cv": "loo"}, "validation.cv", "logo, kfold, dataset or none"),
    ({"cv": "kfold"}, "validation.folds", "needs the number of folds"),
    ({"cv": "logo", "folds": 3}, "validation.folds", "only used with cv: kfold"),
    ({"cv": "kfold", "folds": 1}, "validation.folds", ">= 2"),
    ({"cv": "logo", "budget_fraction": 0}, "validation.budget_fraction", "(0, 1]"),
    ({"cv": "logo", "budget_fraction": 1.5}, "validation.budget_fraction", "(0, 1]"),
    ({"cv": "logo", "gap_warn_abs": -1}, "validation.gap_warn_abs", "[0, inf]"),
    ({"cv": "logo", "gap": 1}, "validation.gap", "unknown key"),
    ({"select": {"top_k": 1}}, "validation.select.top_k", ">= 2"),
    ({"select": {"holdout": 0.9}}, "validation.select.holdout", "fraction in (0, 0.5]"),
    ({"select": {"k": 3}}, "validation.select.k", "unknown key"),
    ([1], "validation", "expected a mapping"),
])
def test_bad_validation_section_names_the_key(tmp_path, section, key, what):
    with pytest.raises(ConfigError) as err:
        config_from_dict(_raw(tmp_path, section), source="job.yaml")
    assert err.value.key == key and what in err.value.message and "job.yaml" in str(err.value)


def test_absent_section_leaves_the_resolved_config_unchanged(tmp_path):
    cfg = config_from_dict(_raw(tmp_path))
    assert "validation" not in cfg.raw and not cfg.validation.active
    assert config_from_dict(_raw(tmp_path, {"cv": "none"})).validation.cv is None


def test_large_gap_rule():
    v = ValidationConfig(gap_warn_rel=0.25, gap_warn_abs=0.6)
    assert not v.gap_is_large(0.5, 2.4)            # 0.5 < 0.6 and < 25 % of 2.4
    assert v.gap_is_large(0.61, 10.0)              # absolute threshold
    assert v.gap_is_large(0.3, 1.0)                # relative: 30 % > 25 %
    assert not v.gap_is_large(math.nan, 1.0)
    assert not ValidationConfig().gap_is_large(0.6, 10.0)  # no absolute threshold by default


@pytest.mark.slow
def test_run_with_cv_writes_tables_and_the_report_shows_the_gap(tmp_path):
    cfg = config_from_dict(_raw(tmp_path, {"cv": "kfold", "folds": 2, "budget_fraction": 0.5, "gap_warn_rel": 0.0}))
    res = run(cfg, quiet=True)
    rd = RunDir(res.run_dir)
    val = rd.validation()["cv"]
    best = rd.best()
    # tuning score: the run's best scored on the held-out folds, weighted by recordings = plain score on all
    direct = FilterObjective("madgwick", SPECS, metric="broad_mean_rmse").score(best.params).fitness
    assert val["tuning_score"] == pytest.approx(direct, rel=1e-12)
    folds = list(val["per_fold"].values())
    assert val["cv_score"] == pytest.approx(sum(folds) / 2)  # two folds of two recordings
    held0 = FilterObjective("madgwick", [SPECS[0], SPECS[2]], metric="broad_mean_rmse")
    rows = (rd.path / "cv.csv").read_text().splitlines()
    beta0 = float(rows[1].split(",")[-1])
    assert folds[0] == pytest.approx(held0.score({"beta": beta0}).fitness, rel=1e-9)
    assert val["gap"] == pytest.approx(val["cv_score"] - val["tuning_score"])
    assert val["gap_large"] == (val["gap"] > 0)  # gap_warn_rel 0: any positive gap is large
    assert best.evaluation["cv_fitness"] == val["cv_score"] and best.evaluation["cv_gap"] == val["gap"]
    assert val["budget_fraction"] == 0.5 and val["folds"] == 2
    md = (rd.path / "report.md").read_text()
    assert "## Generalisation" in md and "gap (CV - tuning)" in md and "(cv.md)" in md
    assert ("**generalisation gap**" in md) == val["gap_large"]
    assert "| fold-0 | 2 |" in (rd.path / "cv.md").read_text()


def test_budget_fraction_scales_generations_and_max_evals(tmp_path):
    from tuner.cv import scaled_budget

    cfg = config_from_dict(_raw(tmp_path, optimizer={"method": "pso", "population": 4, "generations": 10}))
    assert scaled_budget(cfg, 1.0) is cfg
    assert scaled_budget(cfg, 0.5).optimizer.generations == 5 and scaled_budget(cfg, 0.01).optimizer.generations == 1
    capped = config_from_dict(_raw(tmp_path, optimizer={"method": "random", "population": 4, "max_evals": 40}))
    assert scaled_budget(capped, 0.25).optimizer.options["max_evals"] == 10


@pytest.mark.slow
def test_cv_of_a_finished_run_writes_into_it(tmp_path, capsys):
    res = run(config_from_dict(_raw(tmp_path)), quiet=True, report=False)  # the report read below is tuner cv's
    assert not (res.run_dir / "cv.md").exists()
    assert main(["cv", str(res.run_dir), "--k", "2", "-q"]) == 0
    rd = RunDir(res.run_dir)
    val = rd.validation()["cv"]
    assert (res.run_dir / "cv.csv").exists() and val["kind"] == "kfold" and val["folds"] == 2
    direct = FilterObjective("madgwick", SPECS, metric="broad_mean_rmse").score(rd.best().params).fitness
    assert val["tuning_score"] == pytest.approx(direct, rel=1e-12)
    assert rd.best().evaluation["cv_fitness"] == val["cv_score"]
    assert "## Generalisation" in (res.run_dir / "report.md").read_text()
    assert "gap" in capsys.readouterr().out


@pytest.mark.slow
def test_sweep_report_has_the_gap_column(tmp_path):
    from tuner.sweep import collect, run_sweep

    base = _raw(tmp_path, {"cv": "kfold", "folds": 2, "budget_fraction": 0.5})
    base["optimizer"]["generations"] = 1
    doc = {"sweep": {"name": "valsweep", "base": base, "seeds": [1]}}
    (tmp_path / "s.yaml").write_text(yaml.safe_dump(doc))
    out = run_sweep(tmp_path / "s.yaml", sweep_dir=tmp_path / "sw", quiet=True)
    d = Path(out["dir"]) if isinstance(out, dict) and "dir" in out else tmp_path / "sw"
    df = collect(d)
    assert {"cv_fitness", "cv_gap"} <= set(df.columns)
    row = df.iloc[0]
    assert row["cv_gap"] == pytest.approx(row["cv_fitness"] - RunDir(d / "jobs" / row["job"]).validation()[
        "cv"]["tuning_score"])
    assert "cv_gap" in (d / "report.md").read_text()


# --- final selection on a held-out fold: a synthetic overfit ----------------------------------------
class OverfitObjective:
    """1-D ``x`` in [0, 1]. Every recording has a broad basin at 0.3; the tuning recordings (``r0``, ``r1``)
    also share a narrow dip at 0.8 that the held-out ones (``r2``, ``r3``) lack, deep enough that the
    tuning optimum sits in the dip: fitting the tuning data's quirk (the overfit)."""

    def __init__(self, names=("r0", "r1", "r2", "r3")):
        self.names = tuple(names)

    @staticmethod
    def per(name, x):
        base = (x - 0.3) ** 2
        return base - (0.3 * math.exp(-((x - 0.8) / 0.05) ** 2) if name in ("r0", "r1") else 0.0)

    def __call__(self, params):
        return sum(self.per(n, params["x"]) for n in self.names) / len(self.names)

    def default_params(self):
        return {"x": 0.5}

    def cv_folds(self, k=None):
        return [("magnets", OverfitObjective(("r0", "r1")), OverfitObjective(("r2", "r3"))),
                ("quirk", OverfitObjective(("r2", "r3")), OverfitObjective(("r0", "r1")))]

    @classmethod
    def from_config(cls, section, base_dir=None):
        return cls()


overfit_kind = kind_fixture("overfit_kind", "overfit_test", OverfitObjective)


def test_selection_by_held_out_fold_changes_the_choice_of_an_overfit_tuning(tmp_path, overfit_kind):
    raw = {"name": "overfit", "seed": 0, "output": str(tmp_path / "runs"), "objective": {"kind": overfit_kind},
           "parameters": {"x": {"low": 0.0, "high": 1.0}}, "optimizer": {"method": "random", "population": 40,
                                                                          "generations": 2},
           "parallel": {"backend": "serial"}, "validation": {"select": {"top_k": 8, "holdout": "magnets"}}}
    res = run(config_from_dict(raw), quiet=True)
    rd = RunDir(res.run_dir)
    best, sel = rd.best(), rd.best().evaluation["selection"]
    rows = [r for r in rd.history_rows() if r["status"] == "ok"]
    # the run tuned on r0, r1 only: its history's best is in the dip at 0.8
    tuned = min(rows, key=lambda r: float(r["fitness"]))
    assert abs(float(tuned["x"]) - 0.8) < 0.1
    assert float(tuned["fitness"]) == pytest.approx(OverfitObjective(("r0", "r1"))({"x": float(tuned["x"])}))
    # the chosen candidate is the held-out best among the top 8 distinct, and it differs from the tuning best
    held = OverfitObjective(("r2", "r3"))
    assert sel["changed"] and sel["tuning_best_eval"] == int(tuned["eval"]) and sel["holdout"] == "magnets"
    assert len(sel["candidates"]) == 8
    for c in sel["candidates"]:
        x = float(next(r["x"] for r in rows if int(r["eval"]) == c["eval"]))
        assert c["holdout_fitness"] == pytest.approx(held({"x": x}))
    assert best.eval == min(sel["candidates"], key=lambda c: c["holdout_fitness"])["eval"]
    assert held(best.params) < held({"x": float(tuned["x"])})
    assert abs(best.params["x"] - 0.3) < abs(float(tuned["x"]) - 0.3)
    # best.yaml keeps the chosen candidate's tuning fitness; the report lists both numbers
    assert best.fitness == pytest.approx(OverfitObjective(("r0", "r1"))(best.params))
    md = (rd.path / "report.md").read_text()
    assert "## Final selection on a held-out fold" in md and "(not the tuning best)" in md
    assert json.loads((rd.path / "validation.json").read_text())["selection"]["chosen_eval"] == best.eval


def test_unknown_holdout_fold_is_a_config_error(tmp_path, overfit_kind):
    raw = {"name": "overfit", "objective": {"kind": overfit_kind}, "parameters": {"x": {"low": 0.0, "high": 1.0}},
           "output": str(tmp_path), "optimizer": {"method": "random", "population": 4, "generations": 1},
           "parallel": {"backend": "serial"}, "validation": {"select": {"holdout": "nope"}}}
    with pytest.raises(ConfigError, match="no fold named 'nope'.*magnets"):
        run(config_from_dict(raw), quiet=True)
