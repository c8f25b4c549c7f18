"""Windows of one file and recordings without the run's grouping (issue #39, item 4)."""

from __future__ import annotations

import shutil

import pytest
import yaml

from objectives.attitude.objective import FilterObjective
from tests.conftest import REPO, one_error_line
from tests.conftest import run_tuner as tuner

EXAMPLES = REPO / "configs" / "examples"


@pytest.fixture()
def csv_dir(tmp_path):
    for f in ("imu.csv", "imu_columns.yaml"):
        shutil.copy(EXAMPLES / f, tmp_path / f)
    return tmp_path


def _window(start, stop, **extra):
    return {"csv": {"path": "imu.csv", "columns": "imu_columns.yaml", "start_s": start, "stop_s": stop, **extra}}


def test_windows_of_one_file_have_distinct_names_and_cross_validate(csv_dir):
    specs = [_window(0, 2), _window(2, 4), _window(4, None)]
    obj = FilterObjective("madgwick", specs, metric="euler_rmse_mean", base_dir=str(csv_dir))
    assert [r.name for r in obj.recordings()] == ["imu@0s-2s", "imu@2s-4s", "imu@4s-end"]
    folds = obj.cv_folds(3)
    assert [sorted(r.name for r in f[2].recordings()) for f in folds] == [["imu@0s-2s"], ["imu@2s-4s"],
                                                                          ["imu@4s-end"]]


def test_a_name_collision_names_the_names_and_the_fix(csv_dir):
    specs = [_window(0, 2, name="walk"), _window(2, 4, name="walk"), _window(4, 6, name="run")]
    obj = FilterObjective("madgwick", specs, metric="euler_rmse_mean", base_dir=str(csv_dir))
    with pytest.raises(ValueError, match=r"objective\.data: recording names repeat: 'walk' 2 times \(.*imu\.csv\); "
                                         r".*give each data spec its own `name:`"):
        obj.cv_folds(2)
    cfg = {"name": "w", "seed": 1, "objective": {"kind": "filter", "filter": "madgwick", "metric": "euler_rmse_mean",
                                                 "data": specs},
           "parameters": {"beta": {"low": 0.01, "high": 0.5, "scale": "log"}},
           "optimizer": {"method": "pso", "population": 4, "generations": 2}, "parallel": {"backend": "serial"},
           "validation": {"cv": "kfold", "folds": 2}}
    (csv_dir / "job.yaml").write_text(yaml.safe_dump(cfg))
    one_error_line(tuner("run", "job.yaml", cwd=csv_dir), "'walk' 2 times", "`name:`")


@pytest.mark.slow
def test_evaluate_data_without_the_runs_grouping_scores_ungrouped(csv_dir, broad_dir):
    """A config tuned with BROAD's group-balanced metric, scored on CSV windows that have no trials.json: the
    recordings score ungrouped with one warning, exit 0 (before: a ValueError traceback, exit 1)."""
    trials = ["01_undisturbed_slow_rotation_A", "24_disturbed_tapping_A"]
    cfg = {"name": "g", "seed": 1,
           "objective": {"kind": "filter", "filter": "madgwick", "metric": "broad_mean_rmse",
                         "metric_options": {"group_balanced": True},
                         "data": [{"broad": {"dir": str(broad_dir), "trials": trials, "start_s": 30, "stop_s": 50}}]},
           "optimizer": {"method": "pso", "population": 4, "generations": 2}, "parallel": {"backend": "serial"}}
    (csv_dir / "job.yaml").write_text(yaml.safe_dump(cfg))
    (csv_dir / "data.yaml").write_text(yaml.safe_dump({"data": [_window(0, 3), _window(3, 6)]}))
    out = tuner("evaluate", "job.yaml", "--data", "data.yaml", "--json", cwd=csv_dir)
    assert out.returncode == 0, out.stderr
    assert "Traceback" not in out.stderr
    (warn,) = [w for w in out.stderr.splitlines() if "grouping" in w]
    assert warn.startswith("warning: these recordings lack the run's grouping") and "scored ungrouped" in warn
    ungrouped = yaml.safe_load(out.stdout)
    cfg["objective"]["metric_options"] = {}
    (csv_dir / "plain.yaml").write_text(yaml.safe_dump(cfg))
    plain = yaml.safe_load(tuner("evaluate", "plain.yaml", "--data", "data.yaml", "--json", cwd=csv_dir).stdout)
    assert ungrouped["fitness"] == plain["fitness"] and set(ungrouped["recordings"]) == {"imu@0s-3s", "imu@3s-6s"}
    # the config's own BROAD windows keep their trials' groups (a window is named by its bounds)
    grouped = tuner("evaluate", "job.yaml", "--json", cwd=csv_dir)
    assert grouped.returncode == 0, grouped.stderr
    assert set(yaml.safe_load(grouped.stdout)["recordings"]) == {f"{t}@30s-50s" for t in trials}
