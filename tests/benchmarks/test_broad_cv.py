"""benchmarks/broad_cv.py: a BROAD job cross-validated by the engine (tuner.cv), scored as the domain scores trials."""

from __future__ import annotations

import numpy as np
import pytest

from benchmarks.broad_cv import _search, main
from benchmarks.broad_cv_common import broad_config
from objectives.attitude.trials import score_trials
from tests.conftest import BROAD_DIR as BROAD
from tuner.config import ConfigError
from tuner.cv import cross_validate

TRIALS = ["24_disturbed_tapping_A", "26_disturbed_phone_vibration_A", "28_disturbed_stationary_magnet_A"]


def test_options_become_the_config_a_user_would_write(tmp_path):
    (tmp_path / "a.mat").write_bytes(b"")
    cfg = broad_config("mahony", tmp_path, _search(["Kp", "Ki=0.001:0.1:log"]), {"mag_weight": 0.5},
                       population=4, generations=3, seed=7, aggregation="cvar", alpha=0.5, group_balanced=True,
                       prior=2.0, init="truth", n_jobs=2)
    obj = cfg.objective
    assert obj["filter"] == "mahony" and obj["fixed"] == {"mag_weight": 0.5} and obj["q0"] == "truth"
    assert obj["data"] == [{"broad": {"dir": str(tmp_path.resolve()), "trials": ["a"]}}]
    assert obj["metric_options"] == {"aggregate": "cvar", "alpha": 0.5, "group_balanced": True}
    assert obj["prior"] == {"strength": 2.0, "center": "defaults"}
    assert cfg.seed == 7 and cfg.optimizer.method == "pso" and (cfg.optimizer.population,
                                                                  cfg.optimizer.generations) == (4, 3)
    assert cfg.parallel.n_jobs == 2
    from objectives.attitude.filters import get_filter

    own = {p.name: p for p in get_filter("mahony").space().params}
    assert cfg.parameters["Kp"] == own["Kp"].to_dict()  # NAME alone: the filter's own bounds
    assert cfg.parameters["Ki"] == {"low": 0.001, "high": 0.1, "scale": "log"}
    plain = broad_config("mahony", tmp_path)
    assert plain.parameters is None and "metric_options" not in plain.objective and "prior" not in plain.objective
    with pytest.raises(ValueError, match="cannot search"):
        broad_config("mahony", tmp_path, {"nope": None})
    with pytest.raises(ConfigError):
        broad_config("mahony", tmp_path, population=4, method="no-such-optimizer")


def test_bad_option_is_one_error_line(tmp_path, capsys):
    (tmp_path / "a.mat").write_bytes(b"")
    assert main(["mahony", "--data", str(tmp_path), "--search", "nope", "--out", str(tmp_path / "o.md")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("error: ") and "nope" in err[0]
    assert not (tmp_path / "o.md").exists()
    empty = tmp_path / "empty"
    empty.mkdir()
    assert main(["mahony", "--data", str(empty), "--out", str(tmp_path / "o.md")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "no BROAD .mat files" in err[0]
    with pytest.raises(ConfigError, match="optimizer"):  # a config error names its key
        broad_config("mahony", tmp_path, population=0)


@pytest.mark.broad
@pytest.mark.slow
def test_engine_cv_scores_held_out_trials_as_the_domain_does(tmp_path):
    """Tiny budget on three trials of three groups: three folds, each held-out score equal to the tuned
    parameters run on the held-out trial (score_trials, independent of the objective's scoring path)."""
    cfg = broad_config("mahony", BROAD, {"Kp": None}, trials=TRIALS, population=3, generations=2, seed=5)
    out = cross_validate(cfg)
    assert [f.name for f in out.folds] == ["tapping", "vibration", "stationary_magnet"]
    assert [f.recordings for f in out.folds] == [(t,) for t in TRIALS]
    paths = [str(BROAD / f"{t}.mat") for t in TRIALS]
    defaults = score_trials("mahony", {}, paths)
    for f, path, d in zip(out.folds, paths, defaults):
        assert f.cv_fitness == pytest.approx(score_trials("mahony", f.params, [path])[0], rel=1e-9)
        assert f.default_fitness == pytest.approx(d, rel=1e-9)
        # tuned on the other two trials: its training fitness is their mean at the tuned parameters
        rest = [p for p in paths if p != path]
        assert f.train_fitness == pytest.approx(np.mean(score_trials("mahony", f.params, rest)), rel=1e-9)
    s = out.summary()
    full = score_trials("mahony", out.full.params, paths)
    assert s["tuning_score"] == pytest.approx(full.mean(), rel=1e-9)
    assert s["gap"] == pytest.approx(s["cv_mean"] - full.mean())
    again = cross_validate(cfg)  # same config and seed: the same folds' parameters and scores
    assert [(f.params, f.cv_fitness) for f in again.folds] == [(f.params, f.cv_fitness) for f in out.folds]


@pytest.mark.broad
@pytest.mark.slow
def test_script_appends_the_engine_table(tmp_path, capsys):
    md = tmp_path / "cv.md"
    assert main(["mahony", "--data", str(BROAD), "--trials", *TRIALS[:2], "--search", "Kp", "--pso", "2x1",
                 "--n-jobs", "1", "--no-full", "--out", str(md), "--title", "smoke"]) == 0
    text = md.read_text()
    assert "### smoke" in text and "| tapping | 1 |" in text and "| vibration | 1 |" in text
    assert "SUMMARY" in capsys.readouterr().out
