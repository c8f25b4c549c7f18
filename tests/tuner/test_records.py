"""The typed records of a run directory (tuner.records): a history row written by the directory owner reads back
as the same values, bit for bit, and a malformed one is refused naming the row."""

import math

import numpy as np
import pytest

from tuner.records import ERROR_LIMIT, HistoryRow, RunError, clip_error, read_back
from tuner.rundir import RunDir


def _row(**over):
    base = dict(eval=7, stage=1, generation=3, index=2, params={"beta": 0.1 + 0.2, "n": 3, "mode": "paper"},
                fitness=np.float64(1 / 3), status="ok", error="", seconds=0.0123456789,
                metrics={"rmse": np.float32(0.5), "count": 4, "per": [1.5, 2.0], "tag": "walk", "ok": True})
    return HistoryRow(**{**base, **over})


def test_a_row_is_written_as_the_history_always_wrote_it():
    cells = _row(error="line one\nline two").cells()
    assert cells == {"eval": 7, "stage": 1, "generation": 3, "index": 2, "beta": "0.30000000000000004", "n": 3,
                     "mode": "paper", "fitness": "0.3333333333333333", "status": "ok", "error": "line one line two",
                     "seconds": "0.012346", "rmse": "0.5", "count": 4, "per": "[1.5, 2.0]", "tag": "walk",
                     "ok": "True"}


def test_a_row_appended_to_the_history_reads_back_with_the_same_values(tmp_path):
    rd = RunDir(tmp_path / "run")
    rd.path.mkdir()
    h = rd.history(["beta", "n", "mode"])
    rows = [_row(), _row(eval=8, index=3, status="failed", fitness=math.inf, error="diverged", metrics={})]
    h.append(rows)
    back = [HistoryRow.parse(r, ["beta", "n", "mode"], rd.file("history.csv")) for r in rd.history_rows()]
    assert back[0].params == {"beta": 0.1 + 0.2, "n": 3, "mode": "paper"}
    assert back[0].fitness == 1 / 3 and back[0].seconds == 0.012346
    assert back[0].metrics == {"rmse": 0.5, "count": 4, "per": [1.5, 2.0], "tag": "walk", "ok": "True"}
    assert back[0].metrics == read_back(rows[0].metrics)  # what a live best holds is what a resumed one reads
    assert (back[1].status, back[1].fitness, back[1].error, back[1].metrics) == ("failed", math.inf, "diverged", {})
    assert [(r.eval, r.stage, r.generation, r.index) for r in back] == [(7, 1, 3, 2), (8, 1, 3, 3)]


@pytest.mark.parametrize("change, message", [
    ({"status": "maybe"}, "row eval=7: status 'maybe'"),
    ({"fitness": "abc"}, "row eval=7: fitness/seconds not numbers"),
    ({"generation": "x"}, "row eval=7: eval/stage/generation/index not integers"),
])
def test_a_malformed_row_is_refused_naming_it(tmp_path, change, message):
    row = {k: str(v) for k, v in _row().cells().items()}
    with pytest.raises(RunError, match=f"^{tmp_path}/history.csv: {message}"):
        HistoryRow.parse({**row, **change}, ["beta", "n", "mode"], tmp_path / "history.csv")


def test_a_long_error_is_cut_and_says_how_long_it_was():
    text = "x" * (ERROR_LIMIT + 10)
    assert clip_error(text) == "x" * ERROR_LIMIT + f" [... {ERROR_LIMIT + 10:,} characters, cut to {ERROR_LIMIT:,}]"
    assert clip_error("short") == "short"
