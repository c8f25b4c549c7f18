"""Tuning the correct Madgwick filter on BROAD training trials beats the published grid-search TAGP
(beta = 0.12, the 2010 C code) on trials that were not used for tuning."""

import json

import numpy as np
import pytest

from tests.conftest import BROAD_DIR as BROAD
from tuner.config import config_from_dict
from tuner.run import run

TRAIN = ["01_undisturbed_slow_rotation_A", "10_undisturbed_slow_translation_A", "28_disturbed_stationary_magnet_A"]
TEST = ["03_undisturbed_slow_rotation_C", "12_undisturbed_slow_translation_C", "30_disturbed_stationary_magnet_C"]


@pytest.mark.broad
@pytest.mark.slow
def test_tuned_madgwick_beats_published_tagp_on_held_out_trials(tmp_path):
    published = json.loads((BROAD / "published_results.json").read_text())["algorithms"]["madgwick"]["trials"]
    raw = {"name": "broad-madgwick", "seed": 3,
           "objective": {"kind": "filter", "filter": "madgwick", "metric": "broad_mean_rmse",
                         "fixed": {"variant": "paper"},
                         "data": {"train": [{"broad": {"dir": str(BROAD), "trials": TRAIN}}],
                                  "test": [{"broad": {"dir": str(BROAD), "trials": TEST}}]}},
           "parameters": {"beta": {"low": 0.005, "high": 0.5, "scale": "log"}},
           "optimizer": {"method": "pso", "population": 6, "generations": 4, "inertia": "linear",
                         "c1": 1.5, "c2": 1.5},
           "parallel": {"backend": "serial"}}
    res = run(config_from_dict(raw, base_dir=tmp_path), run_dir=tmp_path / "r", quiet=True, report=False)
    ev = res.extra
    tagp_test = np.mean([published[t]["tagp_parameters"]["total_rmse_deg"] for t in TEST])
    tagp_train = np.mean([published[t]["tagp_parameters"]["total_rmse_deg"] for t in TRAIN])
    assert ev["train_fitness"] <= tagp_train
    assert ev["test_fitness"] <= tagp_test, (ev["test_fitness"], tagp_test, res.best_params)
    assert set(ev["test"]) == set(TEST)
