"""`tuner evaluate` loads and checks a config's data as `tuner run` does (the objective's preflight): a CSV with
NaN rows is one error line naming the file and the row, where it was a RecordingError traceback; `--data` that
leaves no recording to score is an error, where it printed fitness nan and exited 0."""

from __future__ import annotations

import shutil

import yaml

from tests.conftest import REPO, one_error_line, run_tuner

EX = REPO / "configs" / "examples"


def _own_csv(tmp_path, nan_rows: bool):
    shutil.copy(EX / "imu_columns.yaml", tmp_path / "imu_columns.yaml")
    lines = (EX / "imu.csv").read_text().splitlines()
    if nan_rows:
        lines[101:104] = [",".join([ln.split(",")[0]] + ["nan"] * (len(ln.split(",")) - 1)) for ln in lines[101:104]]
    (tmp_path / "imu.csv").write_text("\n".join(lines) + "\n")
    cfg = yaml.safe_load((EX / "own_csv.yaml").read_text())
    (tmp_path / "own.yaml").write_text(yaml.safe_dump(cfg))
    return tmp_path / "own.yaml"


def test_evaluate_a_config_whose_csv_has_nan_rows_is_one_error_line(tmp_path):
    line = one_error_line(run_tuner("evaluate", _own_csv(tmp_path, True)), "objective.data[0]", "imu.csv",
                          "non-finite value")
    assert "row 101" in line


def test_evaluate_with_data_that_has_no_recordings_is_an_error(tmp_path):
    cfg = _own_csv(tmp_path, False)
    assert run_tuner("evaluate", cfg).returncode == 0
    for doc in ("data: []\n", "[]\n", "data: {train: [], test: []}\n"):
        (tmp_path / "none.yaml").write_text(doc)
        out = run_tuner("evaluate", cfg, "--data", tmp_path / "none.yaml")
        assert out.returncode == 2 and "Traceback" not in out.stderr and "nan" not in out.stdout, out
        assert "none.yaml" in out.stderr and out.stderr.startswith("error: "), out.stderr


def test_a_recording_without_truth_where_it_is_scored_is_one_error_line_for_run_and_evaluate(tmp_path):
    """Truth cells all empty (a lost reference): nothing to score. Before, `evaluate` ended in a traceback from the
    scoring and `run` in "evaluating the default parameters failed"; now the preflight of both names the
    recording, what is missing and the ways out."""
    cfg = _own_csv(tmp_path, False)
    lines = (tmp_path / "imu.csv").read_text().splitlines()
    (tmp_path / "imu.csv").write_text("\n".join([lines[0]] + [",".join(ln.split(",")[:-4] + [""] * 4)
                                                              for ln in lines[1:]]) + "\n")
    for cmd in ("evaluate", "run"):
        one_error_line(run_tuner(cmd, cfg), "objective.data", "'imu'", "no sample to score",
                       "finite truth quaternion")
    assert not (tmp_path / "runs").exists() or not any((tmp_path / "runs").iterdir())
