"""``tuner cv``: folds from the objective's cv_folds hook, tuned with the config's optimiser, held-out
scores equal to scoring the tuned parameters on the held-out recordings directly."""

from __future__ import annotations

import csv

import pytest
import yaml

from objectives.attitude.objective import FilterObjective
from tests.conftest import BROAD_DIR as BROAD
from tuner.cli import main
from tuner.config import ConfigError, config_from_dict
from tuner.cv import cross_validate, write_cv

SPECS = [{"synthetic": {"generator": "bench6dof", "duration_s": 4, "seed": s}} for s in (1, 2, 3, 4)]


def _cfg(data, tmp_path, **objective):
    return config_from_dict({"name": "cvtest", "seed": 3, "output": str(tmp_path / "runs"),
                             "objective": {"kind": "filter", "filter": "madgwick", "metric": "broad_mean_rmse",
                                           "data": data, **objective},
                             "optimizer": {"method": "pso", "population": 4, "generations": 2},
                             "parallel": {"backend": "serial"}}, base_dir=tmp_path)


def test_kfold_scores_equal_direct_scoring_of_held_out_recordings(tmp_path):
    out = cross_validate(_cfg(SPECS, tmp_path), k=2)
    assert [f.name for f in out.folds] == ["fold-0", "fold-1"] and [f.n_test for f in out.folds] == [2, 2]
    held = {0: [SPECS[0], SPECS[2]], 1: [SPECS[1], SPECS[3]]}  # round-robin assignment
    for i, f in enumerate(out.folds):
        direct = FilterObjective("madgwick", held[i], metric="broad_mean_rmse")
        assert f.cv_fitness == pytest.approx(direct.score(f.params).fitness, rel=1e-12)
        assert f.default_fitness == pytest.approx(direct.score(direct.default_params()).fitness, rel=1e-12)
        train = FilterObjective("madgwick", held[1 - i], metric="broad_mean_rmse")
        assert f.train_fitness == pytest.approx(train.score(f.params).fitness, rel=1e-12)  # tuned on the rest
    s = out.summary()
    assert s["cv_mean"] == pytest.approx(sum(f.cv_fitness * f.n_test for f in out.folds) / 4)
    assert s["gap"] == pytest.approx(s["cv_mean"] - out.full.cv_fitness)
    assert out.full.cv_fitness == pytest.approx(FilterObjective("madgwick", SPECS, metric="broad_mean_rmse").score(
        out.full.params).fitness, rel=1e-12)
    d = write_cv(out, tmp_path / "cv")
    rows = list(csv.DictReader(open(d / "cv.csv")))
    assert [r["fold"] for r in rows] == ["fold-0", "fold-1", "all"]
    assert float(rows[1]["cv_fitness"]) == pytest.approx(out.folds[1].cv_fitness)
    md = (d / "cv.md").read_text()
    assert "| fold-0 | 2 |" in md and "beta" in md and "gap" in md


def test_prior_and_aggregation_tune_but_held_out_score_is_plain(tmp_path):
    cfg = _cfg(SPECS, tmp_path, prior={"strength": 50.0}, metric_options={"aggregate": "worst_k", "k": 1})
    out = cross_validate(cfg, k=2, full=False)
    held = {0: [SPECS[0], SPECS[2]], 1: [SPECS[1], SPECS[3]]}
    for i, f in enumerate(out.folds):
        direct = FilterObjective("madgwick", held[i], metric="broad_mean_rmse")  # the mean, not the worst
        assert f.cv_fitness == pytest.approx(direct.score(f.params).fitness, rel=1e-12)
        tuned = FilterObjective("madgwick", held[1 - i], metric="broad_mean_rmse",
                                metric_options={"aggregate": "worst_k", "k": 1}, prior={"strength": 50.0})
        assert f.train_fitness == pytest.approx(tuned(f.params).fitness, rel=1e-12)  # tuned with both


def test_cli_writes_the_directory_and_bad_k_names_the_problem(tmp_path, capsys):
    (tmp_path / "c.yaml").write_text(yaml.safe_dump({
        "name": "cvcli", "output": str(tmp_path / "runs"), "objective": {"kind": "filter", "filter": "madgwick",
                                                                         "data": SPECS[:3]},
        "optimizer": {"method": "pso", "population": 4, "generations": 1}, "parallel": {"backend": "serial"}}))
    assert main(["cv", str(tmp_path / "c.yaml"), "--k", "3", "-q"]) == 0
    (d,) = list((tmp_path / "runs" / "cv").iterdir())
    assert d.name.startswith("cvcli-") and (d / "cv.md").exists() and (d / "cv.csv").exists()
    with pytest.raises(ConfigError, match="need 2 <= k <= 3"):
        cross_validate(_cfg(SPECS[:3], tmp_path), k=4)


def test_objective_without_cv_hook_is_refused(tmp_path, monkeypatch):
    (tmp_path / "userobj_cv.py").write_text("def f(p):\n    return p['a'] ** 2\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    cfg = config_from_dict({"name": "u", "objective": {"kind": "python", "callable": "userobj_cv:f"},
                            "parameters": {"a": {"low": -1.0, "high": 1.0}},
                            "optimizer": {"method": "pso", "population": 4, "generations": 1}}, base_dir=tmp_path)
    with pytest.raises(ConfigError, match="no cv_folds hook"):
        cross_validate(cfg)


@pytest.mark.broad
def test_broad_leave_one_group_out_on_three_trials(tmp_path):
    trials = ["01_undisturbed_slow_rotation_A", "10_undisturbed_slow_translation_A", "24_disturbed_tapping_A"]
    data = [{"broad": {"dir": str(BROAD), "trials": trials}}]
    out = cross_validate(_cfg(data, tmp_path), full=False)
    assert [f.name for f in out.folds] == ["rotation", "translation", "tapping"]
    for f, t in zip(out.folds, trials):
        direct = FilterObjective("madgwick", [{"broad": {"dir": str(BROAD), "trials": [t]}}], metric="broad_mean_rmse")
        assert f.n_test == 1
        assert f.cv_fitness == pytest.approx(direct.score(f.params).fitness, rel=1e-12)


@pytest.mark.parametrize("flag, expected", [([], 0.5), (["--budget-fraction", "0.25"], 0.25)])
def test_cv_command_uses_the_configs_budget_fraction_unless_given(tmp_path, monkeypatch, flag, expected):
    import tuner.cv

    raw = {"name": "cvtest", "seed": 3, "output": str(tmp_path / "runs"),
           "objective": {"kind": "filter", "filter": "madgwick", "metric": "broad_mean_rmse", "data": SPECS},
           "optimizer": {"method": "pso", "population": 4, "generations": 4},
           "parallel": {"backend": "serial"}, "validation": {"cv": "kfold", "folds": 2, "budget_fraction": 0.5}}
    path = tmp_path / "job.yaml"
    path.write_text(yaml.safe_dump(raw))
    seen = {}
    real = tuner.cv.cross_validate

    def spy(cfg, **kw):
        seen.update(kw)
        return real(cfg, **kw)

    monkeypatch.setattr(tuner.cv, "cross_validate", spy)
    assert main(["cv", str(path), "--k", "2", "--no-full", "--dir", str(tmp_path / "cv"), "-q", *flag]) == 0
    assert seen["budget_fraction"] == expected


@pytest.mark.parametrize("value", ["0", "1.5", "abc"])
def test_cv_command_refuses_a_budget_fraction_outside_0_1(value, capsys):
    with pytest.raises(SystemExit) as exc:
        main(["cv", "job.yaml", "--budget-fraction", value])
    assert exc.value.code == 2
    assert "--budget-fraction: expected a number in (0, 1]" in capsys.readouterr().err
