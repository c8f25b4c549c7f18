"""Aggregation over recordings and the prior as options of the filter objective (metric_options, prior)."""

from __future__ import annotations

import numpy as np
import pytest

from objectives.attitude import metrics as M
from objectives.attitude.filters import get_filter
from objectives.attitude.objective import FilterObjective

SPECS = [{"synthetic": {"generator": "bench6dof", "duration_s": 6, "seed": s}} for s in (1, 2, 3, 4)]
PARAMS = {"Kp": 0.8, "Ki": 0.01}


@pytest.fixture(scope="module")
def per_trial():
    """Independent reference: BROAD's total RMSE of each recording from the metric functions."""
    obj = FilterObjective("mahony", SPECS, metric="broad_mean_rmse")
    flt = get_filter("mahony")(**PARAMS)
    recs = obj.recordings()
    return [r.name for r in recs], np.array([M.broad_errors(flt.run(r), r.quat, r.motion).total_rmse_deg
                                             for r in recs])


def _fit(**kw):
    return FilterObjective("mahony", SPECS, metric="broad_mean_rmse", **kw)(PARAMS).fitness


def test_default_and_explicit_mean_are_bit_identical():
    plain = _fit()
    assert _fit(metric_options={"aggregate": "mean"}) == plain
    assert _fit(prior={"strength": 0.0}) == plain


@pytest.mark.parametrize("opts, ref", [
    ({"aggregate": "median"}, lambda s: np.median(s)),
    ({"aggregate": "worst_k", "k": 1}, lambda s: s.max()),
    ({"aggregate": "worst_k", "k": 2}, lambda s: np.sort(s)[-2:].mean()),
    ({"aggregate": "worst_k", "k": 99}, lambda s: s.mean()),  # k beyond the recordings: all of them
    ({"aggregate": "cvar", "alpha": 0.5}, lambda s: np.sort(s)[-2:].mean()),
    ({"aggregate": "cvar", "alpha": 1.0}, lambda s: s.mean()),
])
def test_aggregations_match_closed_forms(per_trial, opts, ref):
    _, s = per_trial
    assert _fit(metric_options=opts) == pytest.approx(ref(s), rel=1e-10)


def test_group_balanced_mean_is_the_mean_of_group_means(per_trial):
    names, s = per_trial
    groups = {names[0]: "a", names[1]: "a", names[2]: "a", names[3]: "b"}
    got = _fit(metric_options={"group_balanced": True, "groups": groups})
    assert got == pytest.approx((s[:3].mean() + s[3]) / 2, rel=1e-10)
    assert abs(got - s.mean()) > 1e-6  # the weighting changes the number
    obj = FilterObjective("mahony", SPECS, metric="broad_mean_rmse",
                          metric_options={"group_balanced": True, "groups": {names[0]: "a"}})
    with pytest.raises(ValueError, match="metric_options.groups: no group for recording"):
        obj(PARAMS)


def test_prior_penalty_closed_form_and_tuning_only():
    obj = FilterObjective("mahony", SPECS, metric="broad_mean_rmse", prior={"strength": 2.0, "center": "defaults"})
    d = obj.default_params()
    assert obj.prior_penalty(d) == 0.0
    # Kp and Ki are log-scaled over [1e-2, 10] and [1e-5, 1]; Ki's default 0 is clipped onto 1e-5
    u_kp = (np.log10(0.8) - np.log10(d["Kp"])) / 3.0
    u_ki = (np.log10(0.01) - np.log10(1e-5)) / 5.0
    pen = 2.0 * (u_kp**2 + u_ki**2) / 2
    assert obj.prior_penalty(PARAMS) == pytest.approx(pen, rel=1e-12)
    ev = obj(PARAMS)
    assert ev.fitness == pytest.approx(_fit() + pen, rel=1e-12)
    assert obj.score(PARAMS).fitness == _fit()  # reported scores stay the plain metric
    centred = FilterObjective("mahony", SPECS, metric="broad_mean_rmse", prior={"strength": 2.0, "center": PARAMS})
    assert centred.prior_penalty(PARAMS) == 0.0


@pytest.mark.parametrize("kw, msg", [
    ({"metric_options": {"aggregate": "max"}}, r"metric_options.aggregate: unknown"),
    ({"metric_options": {"aggregate": "worst_k"}}, r"metric_options.k: worst_k needs"),
    ({"metric_options": {"aggregate": "cvar", "alpha": 0}}, r"metric_options.alpha: cvar needs"),
    ({"metric_options": {"alpha": 0.5}}, r"metric_options.alpha: only used"),
    ({"metric_options": {"groups": {}}}, r"metric_options.groups: only used"),
    ({"metric_options": {"group_balanced": "yes"}}, r"metric_options.group_balanced"),
    ({"metric": "broad_total_rmse", "metric_options": {"aggregate": "median"}}, r"pools all recordings"),
    ({"prior": {"strength": -1}}, r"prior.strength"),
    ({"prior": {"strength": 1, "centre": "defaults"}}, r"prior.centre: unknown key"),
    ({"prior": {"strength": 1, "center": {"kp": 1}}}, r"prior.center.kp: not a parameter"),
])
def test_bad_options_name_the_key(kw, msg):
    kw = {"metric": "broad_mean_rmse", **kw}
    with pytest.raises(ValueError, match=msg):
        FilterObjective("mahony", SPECS, **kw)


def test_options_survive_with_data_and_config():
    obj = FilterObjective.from_config({"kind": "filter", "filter": "mahony", "data": SPECS[:2],
                                       "metric": "broad_mean_rmse", "metric_options": {"aggregate": "median"},
                                       "prior": {"strength": 1.0}})
    other = obj.with_data(SPECS[2:])
    assert other.metric_options == {"aggregate": "median"} and other.prior == {"strength": 1.0, "center": "defaults"}


def test_report_table_says_how_an_aggregated_fitness_is_made(tmp_path):
    """The run's summary table prints the tuning fitness under the metric's name: with an aggregation over
    recordings it is not the mean of the RMSE columns, and a line under the table says what it is."""
    from objectives.attitude.report import filter_report

    plain = FilterObjective("mahony", SPECS[:2], metric="broad_mean_rmse")
    out = filter_report(plain, tmp_path / "a", PARAMS)
    assert "the fitness" not in out["summary_table"]
    cvar = FilterObjective("mahony", SPECS[:2], metric="broad_mean_rmse",
                           metric_options={"aggregate": "cvar", "alpha": 0.5}, prior={"strength": 2.0})
    table = filter_report(cvar, tmp_path / "b", PARAMS)["summary_table"]
    assert "broad_mean_rmse: the fitness, broad_mean_rmse, cvar (alpha 0.5) over recordings, plus the prior" in table
