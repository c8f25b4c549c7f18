"""Done when: ``configs/broad_mahony.yaml`` run briefly, exported, rebuilt with ``from_run`` and run on
plain arrays (no truth) gives the run's fitness on the same data. The fitness is recomputed here from
the estimates alone: BROAD's total RMSE per trial (:func:`objectives.attitude.metrics.broad_errors`, on
the motion samples), combined as the config says (group-balanced CVaR(0.5) over BROAD's trial groups).
Before the deployment carried ``objective.fixed``, ``Mahony.from_run`` lost ``mag_rejection`` and
``rest_bias`` and scored several degrees worse."""


import numpy as np
import pytest
import yaml

from tests.conftest import BROAD_DIR as BROAD
from tests.conftest import REPO as ROOT
from tests.conftest import run_tuner


@pytest.mark.slow
@pytest.mark.broad
def test_broad_mahony_from_run_on_plain_arrays_gives_the_run_fitness(tmp_path):
    from objectives.attitude.data.loaders import load_recordings
    from objectives.attitude.filters.mahony import Mahony
    from objectives.attitude.metrics import broad_errors
    from objectives.attitude.objective_options import aggregate_scores, recording_groups

    out = run_tuner("run", ROOT / "configs" / "broad_mahony.yaml", "-q", "--no-report",
                    "--set", "optimizer.population=2", "--set", "optimizer.generations=1",
                    "--set", "parallel.backend=serial", "--set", f"output={tmp_path}", cwd=ROOT)
    assert out.returncode == 0, out.stderr
    run_dir = next(p for p in tmp_path.iterdir() if p.is_dir() and (p / "best.yaml").exists())
    best = yaml.safe_load((run_dir / "best.yaml").read_text())
    cfg = yaml.safe_load((ROOT / "configs" / "broad_mahony.yaml").read_text())
    exported = yaml.safe_load(run_tuner("export", run_dir, "--format", "yaml", cwd=ROOT).stdout)
    assert exported["params"]["mag_rejection"] is True and exported["params"]["rest_bias"] is True
    flt = Mahony.from_run(run_dir)
    assert flt.values == Mahony(**exported["params"]).values
    assert flt.values["mag_rejection"] is True and flt.values["rest_bias"] is True and flt.values["Ki"] == 0.0
    recs = load_recordings({"broad": {"dir": str(BROAD), "trials": cfg["objective"]["data"][0]["broad"]["trials"]}})
    # the run tunes without the group its final selection holds out (validation.select): its fitness is on the rest
    held = best["evaluation"]["selection"]["holdout"]
    recs = [r for r in recs if recording_groups(recs, "broad")[r.name] != held]
    assert 0 < len(recs) < 16
    scores = []
    for rec in recs:
        q = flt.run(rec.gyr, rec.acc, rec.mag, rate_hz=1.0 / rec.dt, frame=rec.frame)  # arrays, no truth
        scores.append(broad_errors(q, rec.quat, rec.motion).total_rmse_deg)
    opts = cfg["objective"]["metric_options"]
    fitness = aggregate_scores(scores, [r.name for r in recs], opts, recording_groups(recs, "broad"))
    assert fitness == pytest.approx(best["fitness"], rel=1e-9)
    # the filter of the run's searched values alone (what from_run built before) is not that filter
    bare = Mahony(**{k: v for k, v in best["params"].items() if k in Mahony.defaults})
    bare_scores = [broad_errors(bare.run(r.gyr, r.acc, r.mag, rate_hz=1.0 / r.dt, frame=r.frame), r.quat,
                                r.motion).total_rmse_deg for r in recs]
    assert aggregate_scores(bare_scores, [r.name for r in recs], opts, recording_groups(recs, "broad")) > fitness + 0.5
    assert np.isfinite(scores).all()
