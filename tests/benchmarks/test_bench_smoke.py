"""Smoke run of the benchmark suite (tiny sizes) and the budget bookkeeping it relies on."""

from __future__ import annotations

import json
import math
import subprocess
import sys

import numpy as np
import pytest

from benchmarks.optimizers import METHODS, Budget, Exhausted, available, evals_to_band, run_method
from tests.conftest import REPO

NAMES = ["filters", "closed_loop", "parallel", "optimizers"]


def test_budget_refuses_one_more_and_pads_the_trace():
    b = Budget(lambda u: float(np.sum(u)), 3)
    assert [b([3.0]), b([1.0]), b([2.0])] == [3.0, 1.0, 2.0]
    with pytest.raises(Exhausted):
        b([0.0])
    assert b.trace().tolist() == [3.0, 1.0, 1.0]
    short = Budget(lambda u: 5.0, 4)
    short([0.0])
    assert short.trace().tolist() == [5.0] * 4  # a method that stops early stays flat


def test_evals_to_band_is_first_index_within_threshold():
    t = np.array([9.0, 5.0, 1.01, 1.0])
    assert evals_to_band(t, 1.0101) == 3
    assert evals_to_band(t, 1.0) == 4
    assert math.isinf(evals_to_band(t, 0.5))


@pytest.mark.parametrize("method", METHODS)
def test_every_method_gets_exactly_the_budget(method):
    if not available(method):
        pytest.skip(f"{method}: peer library not installed")
    calls = []

    def f(u):
        calls.append(np.array(u, float))
        return float(np.sum((np.asarray(u) - 0.3) ** 2))

    r = run_method(method, f, 3, 37, 6, seed=1)
    assert r["error"] == ""
    assert r["n_evals"] == len(calls) == 37  # counted by the wrapper, not by the library
    assert all(np.all((c >= 0) & (c <= 1)) for c in calls)  # everyone searches the unit cube
    assert len(r["trace"]) == 37 and np.all(np.diff(r["trace"]) <= 0)
    assert r["trace"][-1] == min(float(np.sum((c - 0.3) ** 2)) for c in calls)


@pytest.mark.slow
def test_smoke_run_writes_well_formed_results(tmp_path):
    p = subprocess.run([sys.executable, "-m", "benchmarks.run", "--smoke", "--out", str(tmp_path)], cwd=REPO,
                       capture_output=True, text=True, timeout=600)
    assert p.returncode == 0, p.stdout[-3000:] + p.stderr[-3000:]
    for name in NAMES:
        data = json.loads((tmp_path / f"{name}.json").read_text(),
                          parse_constant=lambda c, n=name: pytest.fail(f"{n}.json holds {c}"))
        assert data["benchmark"] == name and data["mode"] == "smoke"
        assert "error" not in data, data.get("error")
        m = data["machine"]
        assert m["cores"] >= 1 and m["cpu"] and m["python"] and m["versions"]["numpy"]
        assert isinstance(data["results"], dict) and data["results"]
        for t in data["targets"]:
            assert set(t) == {"target", "value", "pass"} and isinstance(t["pass"], bool)
    filt = json.loads((tmp_path / "filters.json").read_text())["results"]["datasets"]
    for d in filt.values():
        assert d["floor"]["rate"] > 0
        assert all(r["rate"] > 0 for r in d["ours"].values())
    opt = json.loads((tmp_path / "optimizers.json").read_text())["results"]
    for prob in opt["problems"].values():
        for v in prob["methods"].values():
            assert v["seeds"] == len(opt["seeds"]) and not v["errors"]
    summary = (tmp_path / "SUMMARY.md").read_text()
    for name in NAMES:
        assert f"## {name}" in summary
    assert list(tmp_path.glob("quality_*.png"))
