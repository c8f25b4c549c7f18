"""Fixtures the engine's tests share."""

import pytest

from tests.tuner.jobs import sphere_job
from tuner.config import config_from_dict
from tuner.run import run


@pytest.fixture(scope="module")
def finished(tmp_path_factory):
    """The directory of a finished :func:`sphere_job` run, made once per module (copy it before changing it)."""
    tmp = tmp_path_factory.mktemp("fin")
    res = run(config_from_dict(sphere_job(tmp), base_dir=tmp), run_dir=tmp / "run", quiet=True)
    assert res.status == "finished"
    return res.run_dir

