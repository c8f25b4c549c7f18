"""backend: threads: the objective's evaluate_batch hook, its fallbacks, failures, timeouts and seeds."""

import math
import time

import numpy as np
import pytest

from tests.serial import serial_outcomes
from tuner.config import ConfigError, config_from_dict
from tuner.evaluate import Evaluator, TimedObjective
from tuner.loop import SeededCall, evaluation_seed, minimize
from tuner.objective import HOOKS, Evaluation, hook
from tuner.optimizers import get_optimizer
from tuner.space import Real, Space


def _value(p):
    a = p["a"]
    if a > 0.9:
        raise ValueError(f"a too large: {a}")
    if 0.8 < a <= 0.9:
        return math.nan
    return Evaluation((a - 0.3) ** 2, {"a2": a * a})


class Plain:
    """Serial reference: raises for a > 0.9, NaN for 0.8 < a <= 0.9."""

    def __call__(self, p):
        return _value(p)


class Batched(Plain):
    """The same objective with a batch hook that records how it was called."""

    def __init__(self, answer="batch", hang_above=None):
        self.calls = []
        self.answer = answer
        self.hang_above = hang_above

    def evaluate_batch(self, params_list, n_threads):
        self.calls.append((len(params_list), n_threads))
        if self.answer == "none":
            return None
        if self.answer == "raise":
            raise RuntimeError("broken hook")
        if self.hang_above is not None and any(p["a"] > self.hang_above for p in params_list):
            time.sleep(3600)
        return serial_outcomes(_value, params_list)


class SeededBatched:
    """A stochastic objective (takes_seed) whose batch hook receives the seeds."""

    takes_seed = True

    def __call__(self, p, seed=None):
        return p["a"] + np.random.default_rng(seed).random()

    def evaluate_batch(self, params_list, n_threads, seeds=None):
        return [p["a"] + np.random.default_rng(s).random() for p, s in zip(params_list, seeds)]


PARAMS = [{"a": a} for a in (0.1, 0.5, 0.85, 0.95, 0.3, 0.7)]


def _rows(records):
    return [(r.evaluation.fitness, r.evaluation.status, r.evaluation.error, r.evaluation.metrics, r.raised)
            for r in records]


def test_evaluate_batch_is_a_declared_hook():
    assert "evaluate_batch" in HOOKS
    assert hook(Plain(), "evaluate_batch") is None
    assert hook(Batched(), "evaluate_batch") is not None


def test_threads_equal_serial_including_failures():
    with Evaluator(Plain(), "serial") as ev:
        ref = ev(PARAMS)
    obj = Batched()
    with Evaluator(obj, "threads", n_jobs=2) as ev:
        got = ev(PARAMS)
        assert ev.notes == [] and ev.describe().startswith("threads, 2")
    assert obj.calls == [(len(PARAMS), 2)]  # one call for the whole population
    assert _rows(got) == _rows(ref)
    assert got[3].raised and got[3].evaluation.error.startswith("ValueError: a too large: 0.95 at test_evaluate")
    assert got[2].evaluation.status == "failed" and "non-finite" in got[2].evaluation.error
    assert all(r.seconds >= 0 for r in got)


@pytest.mark.parametrize("objective, why", [(Plain(), "has no evaluate_batch hook"),
                                            (Batched("none"), "cannot batch this configuration"),
                                            (Batched("raise"), "evaluate_batch raised RuntimeError: broken hook")])
def test_without_a_usable_hook_threads_fall_back_to_serial_with_a_note(objective, why, capsys):
    with Evaluator(Plain(), "serial") as ev:
        ref = ev(PARAMS)
    with Evaluator(objective, "threads", n_jobs=2) as ev:
        got = ev(PARAMS)
        ev(PARAMS)
        assert len(ev.notes) == 1 and why in ev.notes[0]
    assert _rows(got) == _rows(ref)
    assert capsys.readouterr().err.count("note: backend threads") == 1  # said once, not per batch


@pytest.mark.slow
def test_a_batch_that_overruns_its_timeout_is_rerun_one_candidate_at_a_time():
    obj = TimedObjective(Batched(hang_above=0.6), 1.0)
    t0 = time.perf_counter()
    with Evaluator(obj, "threads", n_jobs=2) as ev:
        got = ev([{"a": 0.1}, {"a": 0.5}, {"a": 0.95}])
        assert any("re-run one at a time" in n for n in ev.notes)
    assert time.perf_counter() - t0 < 30
    assert [r.evaluation.status for r in got] == ["ok", "ok", "failed"]
    assert got[0].evaluation.fitness == pytest.approx(0.04)
    assert got[2].evaluation.error.startswith("ValueError: a too large")


@pytest.mark.slow
def test_a_hung_candidate_times_out_as_in_the_serial_backend():
    class Hangs(Batched):
        def __call__(self, p):
            if p["a"] > 0.6:
                time.sleep(3600)
            return _value(p)

    with Evaluator(TimedObjective(Hangs(hang_above=0.6), 1.0), "threads", n_jobs=2) as ev:
        got = ev([{"a": 0.1}, {"a": 0.7}])
    assert got[0].evaluation.status == "ok"
    assert got[1].evaluation.status == "failed" and got[1].evaluation.error.startswith("timeout: no result after 1 s")


def test_with_a_generous_timeout_the_batch_runs_in_one_child_with_the_same_results():
    with Evaluator(Plain(), "serial") as ev:
        ref = ev(PARAMS)
    with Evaluator(TimedObjective(Batched(), 30.0), "threads", n_jobs=2) as ev:
        got = ev(PARAMS)
        assert ev.notes == []
    assert _rows(got) == _rows(ref)


def test_threads_pass_the_per_evaluation_seeds_as_the_serial_loop_does():
    space = Space([Real("a", 0.0, 1.0)])
    out = {}
    for backend in ("serial", "threads"):
        recorded: list[float] = []

        def keep(g, recorded=recorded):
            recorded.extend(r.evaluation.fitness for r in g.records)

        with Evaluator(SeededCall(SeededBatched()), backend, n_jobs=2) as ev:
            opt = get_optimizer("pso")(1, np.random.default_rng(1), population=5, generations=2)
            res = minimize(SeededBatched(), space, opt, evaluate=lambda fn, items, ev=ev: ev(items), seed=11,
                           callback=keep)
        out[backend] = (recorded, res.fitness)
    assert out["serial"] == out["threads"]
    first = SeededBatched()({"a": 0.0}, seed=evaluation_seed(11, 0))
    assert 0.0 <= first < 1.0


def test_config_accepts_threads_and_names_it_in_the_error():
    raw = {"name": "t", "objective": {"kind": "function", "function": "sphere", "dim": 2},
           "parallel": {"backend": "threads", "n_jobs": 2}}
    assert config_from_dict(raw, source="t.yaml").parallel.backend == "threads"
    with pytest.raises(ConfigError, match="allowed: serial, loky, dask, threads"):
        config_from_dict({**raw, "parallel": {"backend": "thread"}}, source="t.yaml")
