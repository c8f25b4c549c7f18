"""The optimisation loop, and nothing else: ask, decode, evaluate, tell, until the optimiser is done.

:func:`minimize` touches no file, opens no pool and owns no randomness beyond handing evaluation
``i`` its seed. Evaluation is any map-like callable ``evaluate(fn, items) -> results in order``
(plain ``map`` by default, a process pool or a cluster in a run); a ``callback`` sees every
generation (the run writes its history and checkpoint there). Runs, the per-trial optimum of the
attitude reports and the benchmarks all go through it.

Per-evaluation seed (STYLE rule 5): when ``seed`` is given, evaluation ``i`` of the run gets
:func:`evaluation_seed` ``(seed, i)``; an objective that declares ``takes_seed = True`` is called as
``objective(params, seed=s)``, any other as ``objective(params)`` (deterministic objectives are
unchanged). The seed depends only on the run seed and the evaluation index, so serial, parallel and
resumed runs give a stochastic objective the same seeds.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from tuner.objective import EvalRecord, SeededCall, as_evaluation
from tuner.space import Space

__all__ = ["minimize", "MinimizeResult", "Generation", "GenerationStats", "BestPoint", "SeededCall",
           "evaluation_seed"]

#: spawn-key prefix of evaluation seeds, so they never coincide with the optimiser streams [seed, stage]
_EVAL_KEY = 0x65766C


def evaluation_seed(run_seed: int, i: int) -> int:
    """The seed of evaluation ``i`` of a run: ``SeedSequence(run_seed, spawn_key=(_EVAL_KEY, i))``, 63 bits."""
    ss = np.random.SeedSequence(int(run_seed), spawn_key=(_EVAL_KEY, int(i)))
    return int(ss.generate_state(1, np.uint64)[0] >> np.uint64(1))


@dataclass(frozen=True)
class BestPoint:
    """The best successful evaluation so far.

    Attributes
    ----------
    params : dict
        Physical parameter values (as decoded by the space).
    fitness : float
        Its fitness (finite).
    metrics : dict
        The objective's metrics of that evaluation.
    stage, generation, eval : int
        Where it was found (refinement stage, generation within the stage, evaluation index).
    """

    params: dict[str, Any]
    fitness: float
    metrics: dict[str, Any]
    stage: int
    generation: int
    eval: int


@dataclass(frozen=True)
class GenerationStats:
    """One point of the convergence curve (``best`` so far, this generation's best and median of ok)."""

    stage: int
    generation: int
    n_evals: int
    best: float
    gen_best: float
    gen_median: float


@dataclass(frozen=True)
class Generation:
    """What the callback sees after each ``tell``."""

    stage: int
    generation: int
    first_eval: int
    params: list[dict[str, Any]]
    records: list[EvalRecord]
    best: BestPoint | None
    stats: GenerationStats
    n_failed: int
    optimizer: Any


@dataclass(frozen=True)
class MinimizeResult:
    """The loop's result.

    Attributes
    ----------
    best : BestPoint or None
        ``None`` if no evaluation succeeded.
    n_evals, n_failed : int
        Evaluations made in this call (and carried in from ``first_eval``), failures among them.
    convergence : tuple of GenerationStats
        One entry per generation of this call.
    stop_reason : str
        The optimiser's reason for stopping.
    """

    best: BestPoint | None
    n_evals: int
    n_failed: int
    convergence: tuple[GenerationStats, ...]
    stop_reason: str

    @property
    def fitness(self) -> float:
        return self.best.fitness if self.best else math.inf


def _record(v: Any) -> EvalRecord:
    return v if isinstance(v, EvalRecord) else EvalRecord(as_evaluation(v), 0.0)


def minimize(objective: Callable[..., Any], space: Space, optimizer: Any,
             evaluate: Callable[[Callable, Sequence], Iterable] = map,
             callback: Callable[[Generation], None] | None = None, *, seed: int | None = None,
             stage: int = 0, first_eval: int = 0, best: BestPoint | None = None,
             n_failed: int = 0) -> MinimizeResult:
    """Run ``optimizer`` on ``objective`` over ``space`` until the optimiser is done.

    Parameters
    ----------
    objective : callable
        ``objective(params) -> Evaluation | float | (float, dict)`` (``objective(params, seed=s)`` if it
        has ``takes_seed = True`` and ``seed`` is given). A :class:`SeededCall` is used as is.
    space : Space
        Maps the optimiser's unit cube to physical parameters.
    optimizer : tuner.optimizers.Optimizer
        A fresh (or restored) ask/tell optimiser of dimension ``space.dim``.
    evaluate : callable
        ``evaluate(fn, items)`` returning results in the order of ``items`` (``map``, a pool's map).
        Results may be :class:`~tuner.evaluate.EvalRecord` (guarded evaluation) or raw objective values.
    callback : callable, optional
        Called with a :class:`Generation` after each ``tell``; an exception it raises ends the loop.
    seed : int, optional
        Run seed for the per-evaluation seeds; without it items are plain parameter dicts.
    stage, first_eval, best, n_failed :
        Carried over between refinement stages: stage number, index of the next evaluation, best so
        far and failures so far.
    """
    call = objective if (seed is None or isinstance(objective, SeededCall)) else SeededCall(objective)
    n_evals = first_eval
    conv: list[GenerationStats] = []
    while not optimizer.done:
        u = optimizer.ask()
        params = [space.decode(row) for row in u]
        items: list[Any] = params if seed is None else \
            [(p, evaluation_seed(seed, n_evals + i)) for i, p in enumerate(params)]
        records = [_record(r) for r in evaluate(call, items)]
        if len(records) != len(params):
            raise RuntimeError(f"evaluate returned {len(records)} results for {len(params)} candidates")
        f = np.array([r.evaluation.fitness for r in records], dtype=float)
        optimizer.tell(u, f)
        gen = optimizer.generation - 1
        for i, (p, r) in enumerate(zip(params, records)):
            ev = r.evaluation
            if ev.status == "ok" and (best is None or ev.fitness < best.fitness):
                best = BestPoint(dict(p), float(ev.fitness), dict(ev.metrics), stage, gen, n_evals + i)
            n_failed += ev.status != "ok"
        first, n_evals = n_evals, n_evals + len(records)
        ok = f[[r.evaluation.status == "ok" for r in records]]
        stats = GenerationStats(stage, gen, n_evals, best.fitness if best else math.inf,
                                float(ok.min()) if len(ok) else math.nan,
                                float(np.median(ok)) if len(ok) else math.nan)
        conv.append(stats)
        if callback is not None:
            callback(Generation(stage, gen, first, params, records, best, stats, n_failed, optimizer))
    return MinimizeResult(best, n_evals, n_failed, tuple(conv), optimizer.stop_reason)
