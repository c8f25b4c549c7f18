"""Nested CV of fixed choices (``validation: {cv: {..., nested: {choose: ...}}}``): the inner loop chooses on
the fold's own tuning recordings, the outer fold scores the choice it never saw."""

from __future__ import annotations

import csv
import io

import pytest

from objectives.attitude.objective import FilterObjective
from tuner.config import ConfigError, config_from_dict
from tuner.cv import cross_validate, cv_texts

DATA = [{"synthetic": {"generator": "bench6dof", "duration_s": 3, "rate_hz": 200, "seed": s}} for s in range(1, 9)]


def _raw(validation, parameters=None):
    return {"name": "nested", "seed": 4, "parameters": parameters or {"zeta": {"low": 0.0, "high": 0.1}},
            "objective": {"kind": "filter", "filter": "madgwick", "metric": "broad_mean_rmse", "data": DATA},
            "optimizer": {"method": "pso", "population": 3, "generations": 2}, "parallel": {"backend": "serial"},
            "validation": validation}


def test_the_inner_loop_chooses_by_its_held_out_score_and_the_outer_fold_scores_the_choice():
    # beta 5 (written first) is far too high a gain for these benches: every inner loop must reject it
    v = {"cv": {"by": "kfold", "folds": 2, "nested": {"choose": {"beta": [5.0, 0.04]}}},
         "select": {"top_k": 2, "holdout": 0.5}}
    out = cross_validate(config_from_dict(_raw(v)), k=2, full=True)
    for f in out.folds + [out.full]:
        rec = f.selection["nested"]
        fits = {c["choice"]["beta"]: c["inner_fitness"] for c in rec["choices"]}
        assert set(fits) == {5.0, 0.04} and fits[0.04] < fits[5.0]
        assert rec["chosen"] == {"beta": 0.04} and f.params["beta"] == 0.04
    for f in out.folds:  # the outer score is the chosen, tuned parameters scored directly on the held-out fold
        direct = FilterObjective("madgwick", DATA, metric="broad_mean_rmse")
        held = [r for r in direct.recordings() if r.name in f.recordings]
        assert f.cv_fitness == pytest.approx(direct.with_recordings(train=held).score(f.params).fitness, rel=1e-12)
    md, table = cv_texts(out)
    assert "options beta=0.04" in md
    assert [r["nested_choice"] for r in csv.DictReader(io.StringIO(table))][:2] == ["beta=0.04", "beta=0.04"]


@pytest.mark.parametrize("nested, key", [({"choose": {"beta": [0.1]}}, "validation.cv.nested.choose.beta"),
                                         ({"pick": {}}, "validation.cv.nested"),
                                         ({"choose": {"a": [1, 2, 3, 4, 5], "b": [1, 2, 3, 4]}},
                                          "validation.cv.nested.choose")])
def test_bad_nested_choices_name_the_key(nested, key):
    with pytest.raises(ConfigError) as err:
        config_from_dict(_raw({"cv": {"by": "logo", "nested": nested}}))
    assert err.value.key == key


def test_a_nested_option_the_job_does_not_have_is_refused():
    cfg = config_from_dict(_raw({"cv": {"by": "kfold", "folds": 2, "nested": {"choose": {"gain": [1, 2]}}}}))
    with pytest.raises(ConfigError) as err:
        cross_validate(cfg, k=2, full=False)
    assert err.value.key == "validation.cv.nested.choose.gain"
