"""The PID benchmark (benchmarks/pid_benchmark.py) in its smoke size: rules, a short tuning, the table."""

from __future__ import annotations

import math
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
if str(REPO) not in sys.path:
    sys.path.insert(0, str(REPO))

from benchmarks import pid_benchmark as pb  # noqa: E402


def test_rules_on_the_fourth_order_plant_use_the_half_rule():
    """P2 a=0.2 is Skogestad's example: SIMC from the half rule (tests/control/test_loop_rules.py)."""
    from objectives.control.plants.rules import series_to_ideal

    r = pb.rules("P2 a=0.2")
    assert r["SIMC"] == pytest.approx(series_to_ideal(1 / 0.056, 0.224, 0.22))
    K, Ti, Td = r["AMIGO"]
    assert K > 0 and Ti > 0 and Td > 0


@pytest.mark.slow
def test_smoke_run_scores_every_method():
    out = pb.run(smoke=True)
    assert set(out["results"]) == set(list(pb.PLANTS)[:2])
    for res in out["results"].values():
        assert {"AMIGO", "SIMC", "tuner"} <= set(res)
        assert res["tuner"]["ms"] <= pb.MS_MAX + 1e-9 and math.isfinite(res["tuner"]["iae"])
    assert "| P1 n=3 | tuner |" in out["markdown"] and out["targets"]
