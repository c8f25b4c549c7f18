"""A generation of MuJoCo evaluations on threads (``backend: threads``): every (candidate, model) run at once.

:meth:`.loop.MujocoLoop.evaluate_batch` comes here. Python designs each candidate's controller once (a
design that cannot be built fails as in the serial path); the runs, one per candidate and tuning model,
are then dealt to ``n_threads`` threads, grouped by model. Each run is one call of the compiled loop
(:mod:`.kernel`), which holds no GIL and steps MuJoCo through its C functions, so the threads run in
parallel with no Python between two engine steps. A thread keeps one ``mjData`` per model and resets it
before every run (``mj_resetData``: state, warm start, warnings), so which thread runs a pair changes
nothing: each candidate's :class:`~tuner.objective.Evaluation` is scored by the loop's own ``evaluation``
from runs equal to the serial ones, bit for bit (``tests/control/test_mujoco_plant.py``).
"""

from __future__ import annotations

import threading
from collections.abc import Mapping, Sequence
from concurrent.futures import ThreadPoolExecutor
from typing import Any

from objectives.control.design import failed_design

__all__ = ["evaluate_batch", "run_all"]


def run_all(loop: Any, jobs: Sequence[tuple[Any, int]], n_threads: int, plants: Sequence[Any] | None = None,
            cases: Sequence[Any] | None = None) -> list[dict[str, Any]]:
    """The runs of ``jobs`` (``(coefficients, model index)``) on ``n_threads`` threads, in order; the models
    are the loop's tuning set, or ``plants`` with their ``cases`` (the held-out set)."""
    plants = loop.plants if plants is None else plants
    cases = loop.cases if cases is None else cases
    sigs = [loop.signals(c) for c in cases]
    results: list[Any] = [None] * len(jobs)
    local = threading.local()

    def one(i: int) -> None:
        cp, j = jobs[i]
        datas = getattr(local, "datas", None)
        if datas is None:
            datas = local.datas = {}
        if j not in datas:
            datas[j] = plants[j].new_data()
        results[i] = loop.run_case(cp, j, datas[j], plants[j], cases[j], sigs[j])

    order = sorted(range(len(jobs)), key=lambda i: (jobs[i][1], i))
    n = max(1, min(int(n_threads), len(jobs)))
    if n == 1:
        for i in order:
            one(i)
    else:
        with ThreadPoolExecutor(max_workers=n) as pool:
            list(pool.map(one, order))
    return results


def evaluate_batch(loop: Any, params_list: Sequence[Mapping[str, Any]], n_threads: int) -> list[Any]:
    """Evaluations of ``params_list`` equal to the serial ones: an :class:`Evaluation` per candidate, or the
    exception its design raised when that is not a ``ValueError``."""
    results: list[Any] = [None] * len(params_list)
    designed: list[tuple[int, Any]] = []
    for i, params in enumerate(params_list):
        try:
            designed.append((i, loop.coeffs(params)))
        except ValueError as exc:  # as ClosedLoopObjective.__call__: a design that cannot be built
            results[i] = failed_design(exc)
        except Exception as exc:  # noqa: BLE001 - handed back as the serial call would raise it
            results[i] = exc
    n_models = len(loop.cases)
    jobs = [(cp, j) for _, cp in designed for j in range(n_models)]
    runs = run_all(loop, jobs, n_threads)
    for k, (i, _) in enumerate(designed):
        sim = {"t": loop._sc.t, "r": loop._sc.r, "runs": runs[k * n_models:(k + 1) * n_models]}
        results[i] = loop.evaluation(sim, params_list[i])
    return results
