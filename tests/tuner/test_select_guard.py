"""``validation.select`` as a guard: the objective's defaults as a candidate (``include_defaults``) and the same
selection inside every cross-validation fold, so CV measures the procedure a run uses."""

from __future__ import annotations

import json

import pytest

from tests.tuner.kinds import kind_fixture
from tuner.config import ConfigError, config_from_dict
from tuner.cv import cross_validate, cv_texts
from tuner.run import run
from tuner.rundir import RunDir


class GroupedObjective:
    """1-D ``x``; recording ``(name, group, centre)`` costs ``(x - centre)^2``, the objective the mean.

    Default ``x = 0.3``. Group ``hold`` has its optimum at the default, groups ``t1`` and ``t2`` at 0.8:
    tuning on ``t1``/``t2`` overfits to a value that is bad on ``hold``, where the defaults are exact.
    ``cv_folds(None)``: one fold per group; ``cv_folds(k)``: round-robin ``k``-fold.
    """

    RECS = (("h0", "hold", 0.3), ("h1", "hold", 0.3), ("a0", "t1", 0.8), ("a1", "t1", 0.8), ("b0", "t2", 0.8),
            ("b1", "t2", 0.8))

    def __init__(self, recs=RECS):
        self.recs = tuple(recs)

    def __call__(self, params):
        x = float(params["x"])
        return sum((x - c) ** 2 for _, _, c in self.recs) / len(self.recs)

    def default_params(self):
        return {"x": 0.3}

    def cv_folds(self, k=None):
        if k is None:
            groups = list(dict.fromkeys(g for _, g, _ in self.recs))
            if len(groups) < 2:
                raise ValueError("objective.data: fewer than two groups")
            parts = [(g, [r for r in self.recs if r[1] == g]) for g in groups]
        else:
            if not 2 <= k <= len(self.recs):
                raise ValueError(f"cv: need 2 <= k <= {len(self.recs)} (recordings), got k={k}")
            parts = [(f"fold-{i}", [r for j, r in enumerate(self.recs) if j % k == i]) for i in range(k)]
        return [(name, GroupedObjective([r for r in self.recs if r not in held]), GroupedObjective(held))
                for name, held in parts]

    @classmethod
    def from_config(cls, section, base_dir=None):
        return cls()


kind = kind_fixture("kind", "grouped_test", GroupedObjective)


def _raw(tmp_path, kind, select, low=0.0, high=1.0, **val):
    return {"name": "guard", "seed": 0, "output": str(tmp_path / "runs"), "objective": {"kind": kind},
            "parameters": {"x": {"low": low, "high": high}},
            "optimizer": {"method": "random", "population": 20, "generations": 2}, "parallel": {"backend": "serial"},
            "validation": {"select": select, **val}}


def test_include_defaults_is_a_bool_and_on_by_default(tmp_path, kind):
    assert config_from_dict(_raw(tmp_path, kind, {"top_k": 3})).validation.select.include_defaults is True
    with pytest.raises(ConfigError) as err:
        config_from_dict(_raw(tmp_path, kind, {"include_defaults": "yes"}), source="job.yaml")
    assert err.value.key == "validation.select.include_defaults" and "expected bool" in err.value.message


def test_defaults_win_the_final_selection_when_tuning_overfits(tmp_path, kind):
    res = run(config_from_dict(_raw(tmp_path, kind, {"top_k": 5, "holdout": "hold"})), quiet=True)
    rd = RunDir(res.run_dir)
    best, sel = rd.best(), rd.best().evaluation["selection"]
    tune, held = GroupedObjective(GroupedObjective.RECS[2:]), GroupedObjective(GroupedObjective.RECS[:2])
    # every tuned candidate lies near 0.8 (the tuning data's optimum), worse on the held-out fold than 0.3
    assert all(c["holdout_fitness"] > 0.05 for c in sel["candidates"])
    assert sel["defaults"]["holdout_fitness"] == pytest.approx(held({"x": 0.3})) == 0.0
    assert sel["defaults_chosen"] and sel["changed"] and sel["chosen_eval"] == -1
    assert best.params["x"] == 0.3 and best.eval == -1
    assert best.fitness == pytest.approx(tune({"x": 0.3}))  # the defaults' tuning fitness, not the tuning best's
    assert sel["defaults"]["outside_bounds"] == []
    assert json.loads((rd.path / "validation.json").read_text())["selection"]["defaults_chosen"] is True
    md = (rd.path / "report.md").read_text()
    assert "| defaults |" in md and "(not the tuning best)" in md


def test_without_defaults_the_selection_keeps_a_tuned_candidate(tmp_path, kind):
    res = run(config_from_dict(_raw(tmp_path, kind, {"top_k": 5, "holdout": "hold", "include_defaults": False})),
              quiet=True, report=False)
    best = RunDir(res.run_dir).best()
    sel = best.evaluation["selection"]
    assert "defaults" not in sel and not sel.get("defaults_chosen") and best.eval >= 0
    assert abs(best.params["x"] - 0.3) > 0.1


def test_a_default_outside_the_bounds_is_scored_and_named(tmp_path, kind):
    res = run(config_from_dict(_raw(tmp_path, kind, {"top_k": 3, "holdout": "hold"}, low=0.5)), quiet=True)
    best = RunDir(res.run_dir).best()
    sel = best.evaluation["selection"]
    assert sel["defaults"]["outside_bounds"] == ["x"]
    assert sel["defaults_chosen"] and best.params["x"] == 0.3  # not clipped to the bound 0.5
    assert "outside bounds: x" in (res.run_dir / "report.md").read_text()


def test_cv_applies_the_selection_inside_every_fold(tmp_path, kind):
    cfg = config_from_dict(_raw(tmp_path, kind, {"top_k": 4, "holdout": "hold"}))
    out = cross_validate(cfg)
    by = {f.name: f for f in out.folds}
    assert set(by) == {"hold", "t1", "t2"}
    for name in ("t1", "t2"):
        # the fold's tuning data hold group "hold": split off, tuned on the other 0.8 group, defaults win there
        f = by[name]
        assert f.selection["holdout"] == "hold" and f.selection["chosen"] == "defaults"
        assert f.selection["defaults_holdout"] == 0.0 and f.selection["tuning_best_holdout"] > 0.05
        assert f.params["x"] == 0.3
        held = GroupedObjective([r for r in GroupedObjective.RECS if r[1] == name])
        assert f.cv_fitness == pytest.approx(held({"x": 0.3}))  # the chosen parameters are what CV scores
    # the fold holding out "hold" has no such group left: the 0.25 fraction (fold 0 of 4) is the inner fold
    f = by["hold"]
    assert f.selection["holdout"] == "fold-0" and f.selection["chosen"] != "defaults"
    inner_held = GroupedObjective([r for j, r in enumerate(GroupedObjective.RECS[2:]) if j % 4 == 0])
    assert f.selection["holdout_fitness"] == pytest.approx(inner_held(f.params))
    assert f.selection["holdout_fitness"] <= f.selection["tuning_best_holdout"]
    assert f.selection["holdout_fitness"] <= f.selection["defaults_holdout"]
    # the tuning on all data follows the same procedure (named fold present: defaults win)
    assert out.full.selection["chosen"] == "defaults" and out.full.params["x"] == 0.3
    md, table = cv_texts(out, cfg.validation)
    assert "chosen (inner held-out fold)" in md and "| defaults (hold: 0) |" in md
    assert table.splitlines()[0].startswith("fold,n_test,train_fitness,cv_fitness,defaults_fitness,failed,chosen,")


def test_cv_without_select_tunes_each_fold_plainly(tmp_path, kind):
    raw = _raw(tmp_path, kind, {"top_k": 4})
    raw.pop("validation")
    out = cross_validate(config_from_dict(raw))
    assert all(not f.selection for f in out.folds)
    assert abs(next(f for f in out.folds if f.name == "t1").params["x"] - 0.3) > 0.1  # tuned on hold + t2
    assert "chosen" not in cv_texts(out)[0]


def test_inner_split_errors_name_the_key(tmp_path, kind):
    class Tiny(GroupedObjective):
        def cv_folds(self, k=None):
            raise ValueError("cv: need 2 <= k <= 1 (recordings), got k=4")

    from tuner.validation import inner_split

    cfg = config_from_dict(_raw(tmp_path, kind, {"holdout": 0.25}), source="job.yaml")
    with pytest.raises(ConfigError) as err:
        inner_split(cfg.validation.select, Tiny(), cfg.source)
    assert err.value.key == "validation.select.holdout" and "need 2 <= k" in err.value.message


def test_inner_split_falls_back_to_fewer_folds_on_a_small_part(tmp_path, kind):
    """A fold whose tuning part lacks the named group and holds fewer recordings than 1 / 0.25 is split
    into as many folds as it has recordings (here 3), not refused."""
    seen = []

    class Three(GroupedObjective):
        def cv_folds(self, k=None):
            seen.append(k)
            if k is None:
                return [("a", None, None), ("b", None, None), ("c", None, None)]
            if not 2 <= k <= 3:
                raise ValueError(f"cv: need 2 <= k <= 3 (recordings), got k={k}")
            return [(f"fold-{i}", f"train{i}of{k}", f"test{i}of{k}") for i in range(k)]

    from tuner.validation import inner_split

    cfg = config_from_dict(_raw(tmp_path, kind, {"holdout": "hold"}), source="job.yaml")
    assert inner_split(cfg.validation.select, Three(), cfg.source) == ("fold-0", "train0of3", "test0of3")
    assert seen == [None, 4, 3]
    cfg = config_from_dict(_raw(tmp_path, kind, {"holdout": 0.25}), source="job.yaml")
    with pytest.raises(ConfigError):  # an explicit fraction is not bent
        inner_split(cfg.validation.select, Three(), cfg.source)


SPREAD = (("p0", "g1", 0.0), ("p1", "g1", 0.0), ("q0", "g2", 0.6), ("q1", "g2", 0.6), ("r0", "g3", 0.3),
          ("r1", "g3", 0.3))


class SpreadObjective(GroupedObjective):
    """Groups with optima 0.0, 0.6 and 0.3 (the default): every fold's tuning moves off the default towards the
    two groups it sees, so on the held-out group it does worse than the default (CV 0.135 vs 0.06 in closed form),
    although the tuning on all data lands near the default."""

    def __init__(self, recs=SPREAD):
        super().__init__(recs)


spread_kind = kind_fixture("spread_kind", "spread_test", SpreadObjective)


def _cv_raw(tmp_path, kind, **select):
    raw = _raw(tmp_path, kind, None, cv="logo")
    raw["optimizer"] = {"method": "random", "population": 40, "generations": 2}
    if select:
        raw["validation"]["select"] = select
    else:
        raw["validation"].pop("select")
    return raw


def test_the_run_deploys_the_defaults_when_its_cv_says_tuning_does_worse(tmp_path, spread_kind):
    from tuner.verdict import defaults_verdict

    res = run(config_from_dict(_cv_raw(tmp_path, spread_kind)), quiet=True)
    best = RunDir(res.run_dir).best()
    ev = best.evaluation
    assert ev["cv_fitness"] == pytest.approx(0.135, abs=0.02) and ev["defaults_cv_fitness"] == pytest.approx(0.06)
    assert ev["cv_deploys_defaults"] is True and best.params["x"] == 0.3 and best.eval == -1
    assert best.fitness == pytest.approx(SpreadObjective()({"x": 0.3}))  # the defaults' tuning fitness
    line = defaults_verdict(ev)
    assert "the run deploys the defaults (the cross-validation chose them)" in line and "CV" in line
    md = (res.run_dir / "report.md").read_text()
    assert "cross-validation chose them" in md and "| best found at | the objective's defaults" in md


def test_without_defaults_as_a_candidate_the_cv_only_warns(tmp_path, spread_kind):
    from tuner.verdict import defaults_verdict

    res = run(config_from_dict(_cv_raw(tmp_path, spread_kind, top_k=3, holdout=0.5, include_defaults=False)),
              quiet=True, report=False)
    best = RunDir(res.run_dir).best()
    assert "cv_deploys_defaults" not in best.evaluation and best.eval >= 0
    assert best.evaluation["cv_fitness"] > best.evaluation["defaults_cv_fitness"]
    assert "best.yaml holds the tuned values" in defaults_verdict(best.evaluation)
