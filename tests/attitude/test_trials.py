"""BROAD trial groups, folds and trial scoring (objectives.attitude.trials); the CV itself is the engine's."""

from __future__ import annotations

import json

import numpy as np
import pytest

from objectives.attitude.trials import (
    broad_trial_groups,
    kfold_folds,
    load_trial,
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
def test_score_trials_is_broad_total_rmse_and_failures_score_180():
    """Reference: the filter run directly and BROAD's total RMSE computed here over the motion samples."""
    from objectives.attitude.filters import get_filter

    name = "24_disturbed_tapping_A"
    rec = load_trial(BROAD / f"{name}.mat")
    assert load_trial(str(BROAD / f"{name}.mat")) is rec  # loaded once per process
    q = get_filter("mahony")(Kp=0.8).run(rec, q0="accmag")
    qt = rec.quat
    # the heading-and-inclination ("total") error angle of q against the truth, deg
    dot = np.abs(np.sum(q * qt, axis=1)).clip(0.0, 1.0)
    err = np.degrees(2.0 * np.arccos(dot))[rec.motion]
    ref = float(np.sqrt(np.mean(err ** 2)))
    got = score_trials("mahony", {"Kp": 0.8}, [str(BROAD / f"{name}.mat")])
    assert got.shape == (1,) and got[0] == pytest.approx(ref, rel=1e-6)
    assert score_trials("mahony", {"Kp": 0.8}, [str(BROAD / f"{name}.mat")], failure_deg=1.0)[0] == got[0]
    # a filter whose output is not finite is a failure scored failure_deg, not NaN
    bad = score_trials(f"{__name__}:_Diverging", {}, [str(BROAD / f"{name}.mat")] * 2)
    assert bad.tolist() == [180.0, 180.0]
    assert score_trials(f"{__name__}:_Diverging", {}, [str(BROAD / f"{name}.mat")], failure_deg=90.0)[0] == 90.0


class _Diverging:
    """A filter whose output is NaN from the first sample (``score_trials`` takes ``module:Class`` names)."""

    defaults: dict = {}

    def __init__(self, **_values):
        pass

    def run(self, rec, q0=None):
        return np.full((len(rec.quat), 4), np.nan)


@needs_broad
def test_objective_folds_are_the_domain_folds():
    """The filter objective's cv_folds (what `tuner cv` uses) hold out BROAD's groups as logo_folds does."""
    from objectives.attitude.objective import FilterObjective

    names = ["01_undisturbed_slow_rotation_A", "10_undisturbed_slow_translation_A", "24_disturbed_tapping_A",
             "03_undisturbed_slow_rotation_C"]
    obj = FilterObjective.from_config({"kind": "filter", "filter": "mahony", "metric": "broad_mean_rmse",
                                       "data": [{"broad": {"dir": str(BROAD), "trials": names}}]}, BROAD)
    want = logo_folds(names, broad_trial_groups(BROAD, names))
    got = obj.cv_folds()
    assert [g[0] for g in got] == [f.name for f in want] == ["rotation", "translation", "tapping"]
    for (_, train, test), f in zip(got, want):
        assert [r.name for r in test.recordings("train")] == list(f.test)
        assert [r.name for r in train.recordings("train")] == list(f.train)
    kf = obj.cv_folds(2)
    assert [[r.name for r in t.recordings("train")] for _, _, t in kf] == [list(f.test) for f in kfold_folds(names, 2)]
    with pytest.raises(ValueError, match="2 <= k <= 4"):
        obj.cv_folds(5)
