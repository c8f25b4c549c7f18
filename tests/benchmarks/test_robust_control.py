"""The robust-control benchmark (benchmarks/robust_control.py): its smoke size, and the recorded full run."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
if str(REPO) not in sys.path:
    sys.path.insert(0, str(REPO))

from benchmarks import robust_control as rc  # noqa: E402


def test_both_tunings_share_everything_but_the_uncertainty_block():
    for name in rc.PLANTS:
        nominal, robust = rc.job(name, False, 20, 25), rc.job(name, True, 20, 25)
        assert "uncertainty" not in nominal["objective"] and robust["objective"]["uncertainty"]["validate"] == \
            {"samples": 200, "seed": 2}
        robust["objective"].pop("uncertainty")
        robust["objective"].pop("aggregate")
        assert nominal == robust


@pytest.mark.slow
def test_smoke_run_scores_both_tunings_on_held_out_plants():
    out = rc.run(smoke=True)
    (name, res), = out["results"].items()
    for mode in ("nominal", "robust"):
        assert 0.0 <= res[mode]["pass_rate"] <= 1.0 and res[mode]["per_requirement"]
    assert f"| {name} | robust |" in out["markdown"] and out["targets"]


def test_recorded_full_run_meets_its_goal():
    """benchmarks/results/robust_control.json (python -m benchmarks.run --full --only robust_control): on
    every plant the robust tuning passes >= 95 % of the 200 held-out plants, the nominal one at least 10
    points fewer."""
    data = json.loads((REPO / "benchmarks" / "results" / "robust_control.json").read_text())
    assert data["mode"] == "full" and len(data["results"]) >= 3
    for name, res in data["results"].items():
        assert res["robust"]["pass_rate"] >= 0.95, name
        assert res["robust"]["pass_rate"] - res["nominal"]["pass_rate"] >= 0.10, name
