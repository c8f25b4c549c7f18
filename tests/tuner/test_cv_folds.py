"""CV folds say what they hold: tuning recordings only, each fold's recordings listed, ``test:`` recordings
scored on their own next to the CV score; "defaults" is one thing wherever a fixed value is written."""

from __future__ import annotations

import csv
import io

import pytest

from objectives.attitude.objective import FilterObjective
from tuner.config import config_from_dict
from tuner.cv import cross_validate
from tuner.run import run
from tuner.rundir import RunDir

TRAIN = [{"synthetic": {"generator": "bench6dof", "duration_s": 4, "seed": s}} for s in (1, 2, 3, 4)]
TEST = [{"synthetic": {"generator": "bench6dof", "duration_s": 4, "seed": 9}}]


def _raw(tmp_path, data, **extra):
    return {"name": "folds", "seed": 3, "output": str(tmp_path / "runs"),
            "objective": {"kind": "filter", "filter": "madgwick", "metric": "broad_mean_rmse", "data": data},
            "optimizer": {"method": "pso", "population": 4, "generations": 2}, "parallel": {"backend": "serial"},
            **extra}


def test_test_recordings_never_enter_the_folds_and_keep_their_own_score(tmp_path):
    cfg = config_from_dict(_raw(tmp_path, {"train": TRAIN, "test": TEST},
                                validation={"cv": "kfold", "folds": 2, "budget_fraction": 0.5}))
    res = run(cfg, quiet=True, report=False)
    rd = RunDir(res.run_dir)
    val = rd.validation()["cv"]
    obj = FilterObjective("madgwick", TRAIN, TEST, metric="broad_mean_rmse")
    train_names = [r.name for r in obj.recordings("train")]
    (test_name,) = [r.name for r in obj.recordings("test")]
    per_fold = val["per_fold_recordings"]
    assert len(per_fold) == 2
    held = [n for names in per_fold.values() for n in names]
    assert sorted(held) == sorted(train_names)  # every tuning recording held out once, the test one never
    assert per_fold["fold-0"] == [train_names[0], train_names[2]]  # round-robin
    assert val["test_recordings"] == [test_name]
    best = rd.best()
    assert val["test_score"] == pytest.approx(obj.score(best.params, "test").fitness, rel=1e-12)
    defaults = {**obj.default_params(), **cfg.space(obj).fixed}
    assert val["defaults_test_score"] == pytest.approx(obj.score(defaults, "test").fitness, rel=1e-12)
    rows = list(csv.DictReader(io.StringIO((rd.path / "cv.csv").read_text())))
    assert [r["fold"] for r in rows] == ["fold-0", "fold-1", "all", "test"]
    assert rows[0]["recordings"].split(";") == per_fold["fold-0"]
    assert rows[3]["recordings"] == test_name and float(rows[3]["cv_fitness"]) == pytest.approx(val["test_score"])
    md = (rd.path / "cv.md").read_text()
    assert f"- fold-0: {train_names[0]}, {train_names[2]}" in md and f"- test: {test_name}" in md
    assert "*test (never in a fold)*" in md


def test_a_job_without_test_data_has_no_test_row(tmp_path):
    cfg = config_from_dict(_raw(tmp_path, TRAIN[:2]))
    out = cross_validate(cfg, k=2, full=False)
    assert out.test == {} and [len(f.recordings) for f in out.folds] == [1, 1]


def test_cv_refuses_a_single_tuning_recording_even_with_test_data(tmp_path):
    cfg = config_from_dict(_raw(tmp_path, {"train": TRAIN[:1], "test": TEST}))
    from tuner.config import ConfigError

    with pytest.raises(ConfigError, match="needs >= 2 tuning recordings"):
        cross_validate(cfg, k=None, full=False)


def test_both_ways_of_writing_a_fixed_value_give_the_same_defaults_baseline(tmp_path):
    searched = {"beta": {"low": 0.01, "high": 0.5, "scale": "log"}}
    a = _raw(tmp_path, TRAIN[:2], parameters=searched)
    a["objective"]["fixed"] = {"zeta": 0.05}
    b = _raw(tmp_path, TRAIN[:2], parameters={**searched, "zeta": {"fixed": 0.05}})
    outs = [cross_validate(config_from_dict(raw), k=2, full=False) for raw in (a, b)]
    d = [[f.default_fitness for f in o.folds] for o in outs]
    assert d[0] == d[1]
    with_zeta = [FilterObjective("madgwick", [s], fixed={"zeta": 0.05}, metric="broad_mean_rmse").score({}).fitness
                 for s in TRAIN[:2]]
    plain = [FilterObjective("madgwick", [s], metric="broad_mean_rmse").score({}).fitness for s in TRAIN[:2]]
    assert d[0] == pytest.approx(with_zeta, rel=1e-12) and d[0] != pytest.approx(plain, rel=1e-6)
