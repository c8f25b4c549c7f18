"""Folds and the cross-validation driver (objectives.attitude.cv)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from objectives.attitude.cv import (
    TuneOptions,
    broad_trial_groups,
    cross_validate,
    kfold_folds,
    logo_folds,
    score_trials,
    search_space,
)
from tests.conftest import BROAD_DIR as BROAD

needs_broad = pytest.mark.broad


def test_logo_holds_each_name_out_once():
    names = list("abcdefg")
    groups = dict(zip(names, ["x", "x", "y", "z", "y", "x", "z"]))
    folds = logo_folds(names, groups)
    assert [f.name for f in folds] == ["x", "y", "z"]
    held = [n for f in folds for n in f.test]
    assert sorted(held) == names
    for f in folds:
        assert set(f.train) | set(f.test) == set(names) and not set(f.train) & set(f.test)
        assert {groups[n] for n in f.test} == {f.name} and f.name not in {groups[n] for n in f.train}
    with pytest.raises(ValueError, match="no group"):
        logo_folds(names + ["h"], groups)
    with pytest.raises(ValueError, match="two groups"):
        logo_folds(["a", "b"], groups)


def test_kfold_round_robin():
    folds = kfold_folds(list("abcde"), 2)
    assert folds[0].test == ("a", "c", "e") and folds[1].test == ("b", "d")
    with pytest.raises(ValueError, match="2 <= k <= 5"):
        kfold_folds(list("abcde"), 6)


@needs_broad
def test_broad_groups_of_the_shared_trials():
    names = sorted(p.stem for p in BROAD.glob("*.mat"))
    groups = broad_trial_groups(BROAD, names)
    counts = {g: list(groups.values()).count(g) for g in set(groups.values())}
    assert counts == {"rotation": 5, "translation": 4, "tapping": 1, "vibration": 1,
                      "stationary_magnet": 2, "attached_magnet": 3}
    # all 39 trials of the index have exactly one level-2 motion/disturbance group
    assert len(broad_trial_groups(BROAD)) == 39
    with pytest.raises(ValueError, match="not in the index"):
        broad_trial_groups(BROAD, ["99_nope"])


def test_broad_groups_bad_index(tmp_path):
    (tmp_path / "trials.json").write_text(json.dumps({"groups": []}))
    with pytest.raises(ValueError, match="trials.json"):
        broad_trial_groups(tmp_path)


def test_search_space_pins_everything_else():
    sp = search_space("mahony", {"Kp": {"low": 0.1, "high": 2.0, "scale": "log"}}, {"Ki": 0.01})
    assert sp.free_names == ["Kp"]
    assert sp["Ki"].fixed == 0.01
    with pytest.raises(ValueError, match="unknown parameter"):
        search_space("mahony", {"nope": None})


@needs_broad
def test_cross_validate_bookkeeping_and_defaults(tmp_path):
    """Tiny budget on three trials: every trial held out once, budgets counted, defaults scored."""
    names = ["24_disturbed_tapping_A", "26_disturbed_phone_vibration_A", "28_disturbed_stationary_magnet_A"]
    paths = {n: BROAD / f"{n}.mat" for n in names}
    groups = broad_trial_groups(BROAD, names)
    folds = logo_folds(names, groups)
    space = search_space("mahony", {"Kp": None})
    opts = TuneOptions(population=3, generations=2, seed=5)
    res = cross_validate("mahony", paths, folds, groups, space, opts)
    assert sorted(res.cv_deg) == sorted(names)
    assert all(f.n_evals == 6 for f in res.folds) and res.full.n_evals == 6
    direct = score_trials("mahony", {}, [str(paths[n]) for n in names])
    assert np.allclose([res.defaults_deg[n] for n in names], direct)
    # a fold's held-out score is its tuned parameters run on the held-out trial
    f = res.folds[0]
    held = score_trials("mahony", f.params, [str(paths[n]) for n in f.fold.test])
    assert np.allclose(list(f.test_deg.values()), held)
    # the tuned fitness is the minimum over what was evaluated: no worse than the mean at the best params
    assert f.fitness == pytest.approx(np.mean(list(f.train_deg.values())))
    s = res.summary()
    assert s["cv_mean"] == pytest.approx(np.mean(list(res.cv_deg.values())))
    assert s["gap"] == pytest.approx(s["cv_mean"] - s["train_mean"])
    md = res.to_markdown()
    assert "LOGO-CV" in md and all(n in md for n in names)
    # same seed, same result (serial)
    again = cross_validate("mahony", paths, folds, groups, space, opts)
    assert again.cv_deg == res.cv_deg


@pytest.mark.parametrize("kw, msg", [
    ({"aggregation": "max"}, "aggregation must be"), ({"aggregation": "worst_k"}, "k >= 1"),
    ({"aggregation": "cvar", "alpha": 0.0}, "alpha"), ({"init": "first"}, "init must be"),
    ({"population": 0}, ">= 1"), ({"prior_strength": -1.0}, "prior_strength"),
])
def test_tune_options_refuse_bad_values(kw, msg):
    with pytest.raises(ValueError, match=msg):
        TuneOptions(**kw)
