"""Evaluation of a batch of candidates: serially, on local processes (joblib/loky) or on a Dask cluster.

The whole contract is ``evaluator(params_list) == [objective(p) for p in params_list]``, results
in the order asked, whatever the backend (pycma's ``eval_all``). Each evaluation is guarded: an
exception, NaN or inf becomes a failed :class:`~tuner.objective.Evaluation` with the penalty fitness
and the error text, and the run goes on.

Objectives are shipped to workers once: each worker process keeps the first copy it receives in a
module-level cache keyed by a token, so lazy state (loaded recordings, compiled kernels) is built once
per worker, not per evaluation.
"""

from __future__ import annotations

import math
import os
import time
import traceback
import uuid
from dataclasses import dataclass, field
from typing import Any

from tuner.objective import Evaluation, as_evaluation

__all__ = ["Evaluator", "EvalRecord", "BACKENDS", "evaluate_one"]

BACKENDS = ("serial", "loky", "dask")

_WORKER_CACHE: dict[str, Any] = {}


@dataclass(frozen=True)
class EvalRecord:
    """One evaluation as the run records it."""

    evaluation: Evaluation
    seconds: float
    worker: str = field(default="")


def evaluate_one(objective: Any, params: dict[str, Any]) -> EvalRecord:
    """Call the objective once, turning any exception or non-finite result into a failed record."""
    t0 = time.perf_counter()
    try:
        ev = as_evaluation(objective(params))
    except Exception as exc:  # the objective is user code: record what it raised and go on
        tb = traceback.extract_tb(exc.__traceback__)
        where = f" at {tb[-1].filename.rsplit('/', 1)[-1]}:{tb[-1].lineno}" if tb else ""
        ev = Evaluation.failed(f"{type(exc).__name__}: {exc}{where}")
    if ev.status == "ok" and not math.isfinite(ev.fitness):  # pragma: no cover - as_evaluation handles
        ev = Evaluation.failed(f"non-finite fitness {ev.fitness}")
    return EvalRecord(ev, time.perf_counter() - t0, f"{os.getpid()}")


def _eval_chunk(token: str, objective: Any, chunk: list[dict[str, Any]]) -> list[EvalRecord]:
    """Worker side: reuse this process's first copy of the objective (its lazy state survives)."""
    obj = _WORKER_CACHE.get(token)
    if obj is None:
        _WORKER_CACHE.clear()  # a new run in a reused worker: drop the previous objective
        _WORKER_CACHE[token] = obj = objective
    return [evaluate_one(obj, p) for p in chunk]


def _chunks(items: list, n: int) -> list[list]:
    """Split into ``n`` contiguous chunks of nearly equal size (order kept)."""
    n = max(1, min(n, len(items)))
    k, r = divmod(len(items), n)
    out, i = [], 0
    for j in range(n):
        size = k + (1 if j < r else 0)
        out.append(items[i:i + size])
        i += size
    return out


class Evaluator:
    """Map an objective over candidates with the configured backend.

    Parameters
    ----------
    objective : callable
        Picklable ``objective(params) -> Evaluation | float | (float, dict)``.
    backend : {"serial", "loky", "dask"}
        ``serial`` is a plain loop in this process (the debugging path); ``loky`` uses joblib's
        process pool; ``dask`` uses a ``distributed`` client: ``address`` of a running scheduler, or a
        LocalCluster of ``n_jobs`` single-threaded worker processes on 127.0.0.1.
    n_jobs : int
        Worker processes for loky and the local Dask cluster (default 2).
    address : str, optional
        Dask scheduler address, e.g. ``tcp://10.0.0.5:8786``.
    chunks_per_worker : int
        A batch is cut into ``n_jobs * chunks_per_worker`` contiguous chunks (fewer, larger tasks
        keep the overhead low; more, smaller ones balance uneven evaluation times).
    """

    def __init__(self, objective: Any, backend: str = "loky", n_jobs: int = 2, address: str | None = None,
                 chunks_per_worker: int = 4):
        if backend not in BACKENDS:
            raise ValueError(f"unknown backend {backend!r}; known: {list(BACKENDS)}")
        if int(n_jobs) < 1:
            raise ValueError(f"n_jobs must be >= 1, got {n_jobs}")
        self.objective = objective
        self.backend = backend if (backend != "loky" or int(n_jobs) > 1) else "serial"
        self.n_jobs = int(n_jobs)
        self.address = address
        self.chunks_per_worker = int(chunks_per_worker)
        self.token = uuid.uuid4().hex
        self._parallel = None
        self._client = None
        self._cluster = None
        self._remote_obj = None

    # --- lifecycle ----------------------------------------------------------------------------
    def __enter__(self) -> Evaluator:
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()

    def close(self) -> None:
        if self._parallel is not None:
            self._parallel.__exit__(None, None, None)
            self._parallel = None
        if self._client is not None:
            self._client.close()
            self._client = None
        if self._cluster is not None:
            self._cluster.close()
            self._cluster = None

    def describe(self) -> str:
        if self.backend == "serial":
            return "serial"
        if self.backend == "loky":
            return f"loky, {self.n_jobs} workers"
        return f"dask, {self.address or f'LocalCluster({self.n_jobs} workers)'}"

    # --- mapping ------------------------------------------------------------------------------
    def __call__(self, params_list: list[dict[str, Any]]) -> list[EvalRecord]:
        if not params_list:
            return []
        if self.backend == "serial":
            return _eval_chunk(self.token, self.objective, list(params_list))
        chunks = _chunks(list(params_list), self.n_jobs * self.chunks_per_worker)
        if self.backend == "loky":
            results = self._run_loky(chunks)
        else:
            results = self._run_dask(chunks)
        return [r for chunk in results for r in chunk]

    def _run_loky(self, chunks: list[list[dict]]) -> list[list[EvalRecord]]:
        from joblib import Parallel, delayed

        if self._parallel is None:
            self._parallel = Parallel(n_jobs=self.n_jobs, backend="loky", batch_size=1)
            self._parallel.__enter__()
        return self._parallel(delayed(_eval_chunk)(self.token, self.objective, c) for c in chunks)

    def _run_dask(self, chunks: list[list[dict]]) -> list[list[EvalRecord]]:
        if self._client is None:
            try:
                from distributed import Client, LocalCluster
            except ImportError:
                raise RuntimeError(
                    "parallel.backend: dask needs the 'distributed' package: pip install 'tuner[cluster]'"
                ) from None
            if self.address:
                self._client = Client(self.address, timeout="30s")
            else:
                self._cluster = LocalCluster(n_workers=self.n_jobs, threads_per_worker=1, processes=True,
                                             host="127.0.0.1", dashboard_address=None)
                self._client = Client(self._cluster)
            # ship the objective once to every worker; tasks refer to it by future
            self._remote_obj = self._client.scatter(self.objective, broadcast=True, hash=False)
        futures = [self._client.submit(_eval_chunk, self.token, self._remote_obj, c, pure=False) for c in chunks]
        return self._client.gather(futures)
