"""``configs/broad_realtime.yaml`` runs end to end (tuning, the held-out selection with the defaults, the
report, meta.json finished) at a tiny budget: after tuning it used to end in an ``IndexError`` in the
``validation: select`` path and left ``meta.json`` at ``running``."""

import json
from pathlib import Path

import pytest

from tuner.config import config_from_dict
from tuner.safe_yaml import load as yaml_load

CONFIG = Path(__file__).resolve().parents[2] / "configs" / "broad_realtime.yaml"
BROAD = Path(__file__).resolve().parents[3] / "shared" / "data" / "broad"


@pytest.mark.skipif(not BROAD.is_dir(), reason="BROAD trials not found beside the repository")
@pytest.mark.slow
def test_broad_realtime_runs_end_to_end(tmp_path):
    from tuner.run import run

    raw = yaml_load(CONFIG.read_text())
    raw["optimizer"] = {"method": "pso", "population": 3, "generations": 1}
    raw["parallel"] = {"backend": "serial"}
    raw["validation"]["select"]["top_k"] = 2
    res = run(config_from_dict(raw, base_dir=CONFIG.parent), run_dir=tmp_path / "rt", quiet=True)
    assert res.status == "finished"
    meta = json.loads((tmp_path / "rt" / "meta.json").read_text())
    assert meta["status"] == "finished"
    best = yaml_load((tmp_path / "rt" / "best.yaml").read_text())
    sel = best["evaluation"]["selection"]
    assert sel["include_defaults"] and sel["holdout"] == "stationary_magnet"
    assert sel["defaults"]["holdout_fitness"] > 0
    report = (tmp_path / "rt" / "report.md").read_text()
    assert "Final selection on a held-out fold" in report and "optimistic CV" in report
    assert (tmp_path / "rt" / "fingerprint.json").is_file()
