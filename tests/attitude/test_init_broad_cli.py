"""``init: broad`` through the command line reproduces BROAD's published Mahony RMSE per trial.

``tuner evaluate CONFIG --params p.yaml --json`` with ``Kp: 0.74, Ki: 0.0012, init: broad`` (BROAD's
trial-agnostic good parameters and its own start orientation) must match every per-trial total, heading
and inclination RMSE of ``published_results.json`` (Laidig et al., Data 6(7):72, 2021) within 0.01 deg.
The default start (``init: auto`` -> first-sample accmag) is off by up to 0.4 deg, so the test can fail.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest
import yaml

from objectives.attitude.filters.mahony import Mahony
from tests.conftest import BROAD_DIR as BROAD
from tests.conftest import REPO, run_tuner

KEYS = ("total_rmse_deg", "heading_rmse_deg", "inclination_rmse_deg")


def _evaluate(tmp_path: Path, trials: list[str], params: dict) -> dict:
    cfg = {"name": "init-broad", "objective": {
        "kind": "filter", "filter": "mahony", "metric": "broad_mean_rmse",
        "data": [{"broad": {"dir": str(BROAD), "trials": trials}}]},
        "optimizer": {"method": "pso", "population": 4, "generations": 1}}
    (tmp_path / "c.yaml").write_text(yaml.safe_dump(cfg))
    (tmp_path / "p.yaml").write_text(yaml.safe_dump(params))
    out = run_tuner("evaluate", tmp_path / "c.yaml", "--params", tmp_path / "p.yaml", "--json", cwd=REPO)
    assert out.returncode == 0, out.stderr
    return json.loads(out.stdout)


def test_init_is_a_declared_option_of_every_filter():
    assert Mahony.defaults["init"] == "auto"
    with pytest.raises(ValueError, match="init must be one of"):
        Mahony(init="broda")


@pytest.mark.broad
@pytest.mark.slow
def test_cli_reproduces_published_mahony_rmse_per_trial(tmp_path):
    published = json.loads((BROAD / "published_results.json").read_text())["algorithms"]["mahony"]["trials"]
    trials = sorted(t for t in published if (BROAD / f"{t}.mat").exists())
    assert len(trials) >= 10
    got = _evaluate(tmp_path, trials, {"Kp": 0.74, "Ki": 0.0012, "init": "broad"})
    assert got["params"]["init"] == "broad"
    bad = [(t, k, got["recordings"][t][k], published[t]["tagp_parameters"][k])
           for t in trials for k in KEYS
           if abs(got["recordings"][t][k] - published[t]["tagp_parameters"][k]) > 0.01]
    assert not bad, bad
    # without BROAD's start the same parameters miss the published numbers on some trial
    auto = _evaluate(tmp_path, trials, {"Kp": 0.74, "Ki": 0.0012})
    worst = max(abs(auto["recordings"][t]["total_rmse_deg"] - published[t]["tagp_parameters"]["total_rmse_deg"])
                for t in trials)
    assert worst > 0.05
