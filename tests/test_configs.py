"""Every shipped config loads, validates and builds its objective (runnable as is)."""

from pathlib import Path

import pytest

from tuner.config import load_config
from tuner.run import _build
from tuner.sweep import is_sweep_file, load_sweep

CONFIGS = sorted((Path(__file__).resolve().parents[1] / "configs").glob("*.yaml"))
BROAD = Path(__file__).resolve().parents[2] / "shared" / "data" / "broad"


@pytest.mark.parametrize("path", CONFIGS, ids=[p.name for p in CONFIGS])
def test_config_builds(path):
    if "broad" in path.name and not BROAD.is_dir():
        pytest.skip("needs ../shared/data/broad")
    if path.name == "broad_vqf.yaml":
        pytest.importorskip("vqf")
    text = path.read_text()
    assert text.startswith("#"), "each config documents itself at its top"
    if is_sweep_file(path):
        sw = load_sweep(path)
        assert sw["jobs"]
        return
    cfg = load_config(path)
    objective, space = _build(cfg)
    assert space.dim >= 1
