"""``benchmarks.run --summary-only``: rebuilds SUMMARY.md from stored results, refuses to run nothing on nothing."""

from __future__ import annotations

import pytest

from benchmarks.common import write_result
from benchmarks.run import main


def test_summary_only_rebuilds_from_stored_results(tmp_path):
    write_result("optimizers", {"mode": "full", "markdown": "the stored table", "seconds": 3.0,
                                "targets": [{"target": "t1", "value": "1/1", "pass": True}]}, tmp_path)
    assert main(["--full", "--summary-only", "--out", str(tmp_path)]) == 0
    text = (tmp_path / "SUMMARY.md").read_text()
    assert "the stored table" in text and "| optimizers | t1 | 1/1 | pass |" in text


def test_summary_only_without_results_is_an_error_and_writes_nothing(tmp_path, capsys):
    assert main(["--full", "--summary-only", "--out", str(tmp_path)]) == 2
    assert "no stored full benchmark results" in capsys.readouterr().err
    assert not (tmp_path / "SUMMARY.md").exists()


def test_summary_only_with_only_is_a_usage_error(tmp_path):
    with pytest.raises(SystemExit) as exc:
        main(["--full", "--summary-only", "--only", "filters", "--out", str(tmp_path)])
    assert exc.value.code == 2
