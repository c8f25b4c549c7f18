"""Per-problem optimiser-benchmark runs merge into one result without changing a number."""

from __future__ import annotations

import json
import math

from benchmarks.common import write_result
from benchmarks.optimizers import run
from benchmarks.optimizers_merge import merge


def test_merge_keeps_each_problem_and_rebuilds_the_report(tmp_path):
    paths = []
    for prob in ("kf1d_tilt1d", "ekf_bench6dof"):
        res = run(smoke=True, n_jobs=1, out_dir=tmp_path / prob, problems=[prob], methods=["random", "trust_region"],
                  seeds=[0, 1], functions=[])
        paths.append(write_result("optimizers", {"mode": "smoke", **res}, tmp_path / prob))
    merged = merge(paths, tmp_path / "all")
    for prob, p in zip(("kf1d_tilt1d", "ekf_bench6dof"), paths):
        one = json.loads(p.read_text())["results"]["problems"][prob]
        both = merged["results"]["problems"][prob]
        assert both["f_star"] == one["f_star"] and both["threshold"] == one["threshold"]
        for m, v in one["methods"].items():
            w = both["methods"][m]
            assert w["finals"] == v["finals"]
            assert [math.inf if e is None else e for e in v["evals_to_1pct"]] == w["evals_to_1pct"]
        assert f"| {prob} |" in merged["markdown"] and (tmp_path / "all" / f"quality_{prob}.png").exists()
    assert set(merged["results"]["verdicts"]) == {"kf1d_tilt1d", "ekf_bench6dof"}
    assert all(isinstance(t["pass"], bool) for t in merged["targets"])
