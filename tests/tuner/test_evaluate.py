"""Evaluation backends: results in ask order, failures as values, a Dask cluster equal to serial."""

import os

import numpy as np
import pytest

from objectives.functions import FunctionObjective
from tests.tuner.kinds import CountingObjective
from tuner.config import config_from_dict
from tuner.evaluate import Evaluator, _chunks
from tuner.objective import PENALTY, Evaluation, as_evaluation
from tuner.run import run


def test_chunks_keep_order_and_cover_everything():
    items = list(range(23))
    for n in (1, 2, 5, 8, 30):
        ch = _chunks(items, n)
        assert [x for c in ch for x in c] == items
        assert max(map(len, ch)) - min(map(len, ch)) <= 1


def test_as_evaluation_normalises():
    assert as_evaluation(1.5) == Evaluation(1.5, {})
    assert as_evaluation((2.0, {"a": 1.0})).metrics == {"a": 1.0}
    bad = as_evaluation(float("inf"))
    assert bad.status == "failed" and bad.fitness == PENALTY and "inf" in bad.error
    assert as_evaluation("x").status == "failed"


@pytest.mark.parametrize("backend", ["serial", "loky"])
def test_results_in_ask_order(backend):
    obj = FunctionObjective("sphere", 2)
    pts = [{"x0": float(i), "x1": 0.0} for i in range(17)]
    with Evaluator(obj, backend, n_jobs=2) as ev:
        out = ev(pts)
    assert [r.evaluation.fitness for r in out] == [float(i * i) for i in range(17)]


class _Lazy:
    """Counts how often its expensive state is built (in this process)."""

    def __init__(self):
        self.builds = 0
        self._state = None

    def __getstate__(self):  # shipping drops the lazy state, as real objectives do
        return {"builds": 0, "_state": None}

    def __call__(self, params):
        if self._state is None:
            self.builds += 1
            self._state = "loaded"
        return float(self.builds)


def test_objective_built_once_per_worker():
    """A worker keeps the first copy it receives; later copies (of the same run) are not rebuilt."""
    import pickle

    from tuner.evaluate import _eval_chunk

    original = _Lazy()
    token = "run-token"
    first = _eval_chunk(token, pickle.loads(pickle.dumps(original)), [{}] * 3)
    second = _eval_chunk(token, pickle.loads(pickle.dumps(original)), [{}] * 3)
    assert [r.evaluation.fitness for r in first + second] == [1.0] * 6


def test_loky_reuses_worker_processes():
    """Three batches of 8 on 2 workers run in at most 2 processes other than this one, and each worker
    keeps its one copy of the objective across tasks and batches: its call counts run 1, 2, 3, ... (a
    copy per task, one candidate per task here, would count 1 every time)."""
    with Evaluator(CountingObjective(), "loky", n_jobs=2) as ev:
        recs = [r for _ in range(3) for r in ev([{"x0": 1.0}] * 8)]
    pids = {r.worker for r in recs}
    assert str(os.getpid()) not in pids and 1 <= len(pids) <= 2
    for pid in pids:
        counts = sorted(r.evaluation.fitness for r in recs if r.worker == pid)
        assert counts == [float(i) for i in range(1, len(counts) + 1)], pid
    assert max(r.evaluation.fitness for r in recs) > 8  # some copy outlived its first batch


@pytest.mark.slow
def test_dask_local_cluster_equals_serial(tmp_path):
    pytest.importorskip("distributed")
    raw = {"name": "d", "seed": 2, "objective": {"kind": "function", "function": "ackley", "dim": 3},
           "optimizer": {"method": "pso", "population": 6, "generations": 3}, "output": str(tmp_path)}
    a = run(config_from_dict({**raw, "parallel": {"backend": "serial"}}), run_dir=tmp_path / "s", quiet=True,
            report=False)
    b = run(config_from_dict({**raw, "parallel": {"backend": "dask", "n_jobs": 2}}), run_dir=tmp_path / "d",
            quiet=True, report=False)
    assert a.best_params == b.best_params and a.best_fitness == b.best_fitness
    ha = np.loadtxt(tmp_path / "s" / "history.csv", delimiter=",", skiprows=1, usecols=range(4, 8))
    hb = np.loadtxt(tmp_path / "d" / "history.csv", delimiter=",", skiprows=1, usecols=range(4, 8))
    assert np.array_equal(ha, hb)
