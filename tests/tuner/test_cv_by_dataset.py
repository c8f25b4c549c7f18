"""Several datasets: ``dataset:`` labels on data sources, ``validation: {cv: {by: dataset}}`` (leave one dataset
out) and the transfer table, checked against the filter evaluated directly on each dataset."""

from __future__ import annotations

import json

import pytest

from objectives.attitude.data.loaders import load_recordings
from objectives.attitude.data.recording import RecordingError
from objectives.attitude.objective import FilterObjective
from tuner.config import ConfigError, config_from_dict
from tuner.run import run
from tuner.rundir import RunDir

# two sensors: a quiet one, and a noisy one with a large gyro bias (different sensors, one motion generator)
QUIET = [{"synthetic": {"generator": "bench6dof", "duration_s": 4, "rate_hz": 200, "seed": s, "dataset": "quiet",
                        "gyr_noise": 1e-4, "gyr_bias": [0.0, 0.0, 0.0]}} for s in (1, 2)]
NOISY = [{"synthetic": {"generator": "bench6dof", "duration_s": 4, "rate_hz": 200, "seed": s, "dataset": "noisy",
                        "gyr_noise": 5e-3, "gyr_bias": [0.03, -0.02, 0.01], "acc_noise": 0.05}} for s in (3, 4)]
SEARCH = {"beta": {"low": 0.005, "high": 0.5, "scale": "log"}}


def _raw(tmp_path, data, validation):
    return {"name": "transfer", "seed": 5, "output": str(tmp_path / "runs"), "parameters": SEARCH,
            "objective": {"kind": "filter", "filter": "madgwick", "metric": "broad_mean_rmse", "data": data},
            "optimizer": {"method": "pso", "population": 4, "generations": 2}, "parallel": {"backend": "serial"},
            "validation": validation}


def test_a_source_carries_its_dataset_label_and_defaults_to_its_kind():
    recs = load_recordings(QUIET[0])
    assert recs[0].meta["dataset"] == "quiet"
    plain = {"synthetic": {k: v for k, v in QUIET[0]["synthetic"].items() if k != "dataset"}}
    assert load_recordings(plain)[0].meta["dataset"] == "synthetic"
    with pytest.raises(RecordingError, match="'dataset' must be a non-empty text"):
        load_recordings({"synthetic": {**plain["synthetic"], "dataset": 3}})


def test_leave_one_dataset_out_gives_a_transfer_table_equal_to_direct_evaluation(tmp_path):
    cfg = config_from_dict(_raw(tmp_path, QUIET + NOISY, {"cv": {"by": "dataset"}}))
    res = run(cfg, quiet=True, report=True)
    rd = RunDir(res.run_dir)
    cv = rd.validation()["cv"]
    assert cv["kind"] == "dataset"
    assert sorted(cv["per_fold_recordings"]) == ["noisy", "quiet"]
    table = {r["dataset"]: r for r in cv["transfer"]}
    assert sorted(table) == ["noisy", "quiet"]
    rows = {r["fold"]: r for r in _csv(rd)}
    for held, mine in (("quiet", QUIET), ("noisy", NOISY)):
        tuned = {"beta": float(rows[held]["beta"])}
        # the fold's parameters are those tuned on the other dataset only: scored directly on this dataset
        direct_tuned = FilterObjective("madgwick", mine, metric="broad_mean_rmse").score(tuned).fitness
        direct_defaults = FilterObjective("madgwick", mine, metric="broad_mean_rmse").score({}).fitness
        r = table[held]
        assert r["n"] == 2
        assert r["tuned"] == pytest.approx(direct_tuned, rel=1e-12)
        assert r["defaults"] == pytest.approx(direct_defaults, rel=1e-12)
        assert r["difference"] == pytest.approx(direct_tuned - direct_defaults, rel=1e-9, abs=1e-12)
        assert cv["per_fold_recordings"][held] == [x.name for x in FilterObjective("madgwick", mine).recordings()]
    assert table["quiet"]["defaults"] < table["noisy"]["defaults"]  # the sensors differ: the noisy one scores worse
    assert rows["quiet"]["beta"] != rows["noisy"]["beta"]  # each side tuned on the other dataset's data
    md = (rd.path / "cv.md").read_text()
    assert "## Transfer between datasets" in md and "| quiet | 2 |" in md
    report = (rd.path / "report.md").read_text()
    assert "### Transfer between datasets" in report
    assert "transfer (tuned on the other datasets - defaults): " in json.dumps(_dashboard_status(tmp_path))


def _csv(rd):
    import csv

    return list(csv.DictReader((rd.path / "cv.csv").open()))


def _dashboard_status(tmp_path):
    from tuner.dashboard import collect_runs

    return [r.get("status") for r in collect_runs(tmp_path / "runs")]


def test_show_prints_the_transfer_line(tmp_path, capsys):
    from tuner.cli import main

    cfg = config_from_dict(_raw(tmp_path, QUIET[:1] + NOISY[:1], {"cv": {"by": "dataset"}}))
    res = run(cfg, quiet=True, report=False)
    capsys.readouterr()
    assert main(["show", str(res.run_dir)]) == 0
    out = capsys.readouterr().out
    assert "transfer (tuned on the other datasets - defaults): noisy " in out or \
        "transfer (tuned on the other datasets - defaults): quiet " in out


def test_one_dataset_is_one_error_naming_the_key(tmp_path):
    cfg = config_from_dict(_raw(tmp_path, QUIET, {"cv": {"by": "dataset"}}))
    with pytest.raises(ConfigError, match=r"validation\.cv\.by.*needs >= 2 datasets.*'quiet'.*dataset: NAME"):
        run(cfg, quiet=True, report=False)


@pytest.mark.parametrize("validation, key", [({"cv": {"by": "sensor"}}, "validation.cv.by"),
                                             ({"cv": {"by": "dataset", "k": 2}}, "validation.cv.k"),
                                             ({"cv": "dataset2"}, "validation.cv")])
def test_bad_cv_grouping_names_the_key(tmp_path, validation, key):
    with pytest.raises(ConfigError) as err:
        config_from_dict(_raw(tmp_path, QUIET + NOISY, validation))
    assert err.value.key == key


def test_cv_by_kfold_mapping_is_the_kfold_string(tmp_path):
    a = config_from_dict(_raw(tmp_path, QUIET + NOISY, {"cv": {"by": "kfold", "folds": 2}}))
    b = config_from_dict(_raw(tmp_path, QUIET + NOISY, {"cv": "kfold", "folds": 2}))
    assert a.validation == b.validation
