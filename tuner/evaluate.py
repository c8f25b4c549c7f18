"""Evaluation of a batch of candidates: serially, on local processes (joblib/loky), on a Dask cluster, or
in this process on threads through the objective's ``evaluate_batch`` hook.

The whole contract is ``evaluator(params_list) == [objective(p) for p in params_list]``, results
in the order asked, whatever the backend (pycma's ``eval_all``). Each evaluation is guarded: an
exception, NaN or inf becomes a failed :class:`~tuner.objective.Evaluation` with the penalty fitness
and the error text, and the run goes on.

An objective's ``SystemExit`` and its own ``KeyboardInterrupt`` are failures too; a SIGINT delivered to
the process (the user's Ctrl-C) still stops the run. With ``objective.timeout_s`` the objective is a
:class:`TimedObjective` and each evaluation runs in a forked child that is killed when time is up. A
loky worker that dies takes no result with it: its candidates are re-run one at a time and those that
kill a worker again are recorded as failed.

The ``threads`` backend hands the whole population to the objective's ``evaluate_batch`` hook (one
numba kernel over candidates x recordings, threads sharing the data: no pickling, no worker
processes, one copy of the data); an objective without the hook, or one whose hook returns None for
its configuration, is evaluated serially with a one-line note. With ``objective.timeout_s`` the batch
runs in one forked child with a deadline of ``timeout_s`` per round of ``n_jobs`` candidates; when it
does not answer in time, the batch is re-run one candidate at a time, each in its own child with its
own timeout, so the failures recorded are the serial backend's. A Ctrl-C is handled when the
running batch returns (a kernel cannot be interrupted).

Objectives are shipped to workers once: each worker process keeps the first copy it receives in a
module-level cache keyed by a token, so lazy state (loaded recordings, compiled kernels) is built once
per worker, not per evaluation.
"""

from __future__ import annotations

import math
import os
import signal
import sys
import threading
import time
import traceback
import uuid
from typing import Any

from tuner import signals as _signals
from tuner.objective import EvalRecord, Evaluation, SeededCall, as_evaluation, hook

__all__ = ["Evaluator", "EvalRecord", "BACKENDS", "evaluate_one", "TimedObjective"]

BACKENDS = ("serial", "loky", "dask", "threads")

_WORKER_CACHE: dict[str, Any] = {}


class _SigintWatch:
    """Count stop signals (Ctrl-C, SIGTERM, SIGHUP; :mod:`tuner.signals`) delivered to this process, so
    that a KeyboardInterrupt raised by an objective's own code (a recorded failure) is told apart from
    the user's Ctrl-C or a scheduler's SIGTERM (which stop the run)."""

    @staticmethod
    def count() -> int:
        return _signals.count()

    @staticmethod
    def install(others: bool = False) -> None:
        _signals.install(sigint=True, others=others)


def watch_sigint() -> int:
    """Count this process's SIGINTs (and SIGTERM/SIGHUP) from now on (main thread; handlers at their
    defaults only); the count so far.

    A run compares the count at each generation's end: a Ctrl-C whose KeyboardInterrupt was swallowed
    (by an objective that catches it, or raised inside a ``__del__`` where Python only prints it) still
    stops the run there.
    """
    _SigintWatch.install(others=True)
    return _SigintWatch.count()


def sigint_count() -> int:
    """Stop signals counted since :func:`watch_sigint` (0 when not watched)."""
    return _SigintWatch.count()


def _failure(exc: BaseException) -> Evaluation:
    tb = traceback.extract_tb(exc.__traceback__)
    where = f" at {tb[-1].filename.rsplit('/', 1)[-1]}:{tb[-1].lineno}" if tb else ""
    return Evaluation.failed(f"{type(exc).__name__}: {exc}{where}")


def _call(objective: Any, params: dict[str, Any]) -> tuple[Evaluation, bool]:
    """(evaluation, raised): exceptions, SystemExit and an objective's own KeyboardInterrupt are failures."""
    seen = _SigintWatch.count()
    try:
        return as_evaluation(objective(params)), False
    except KeyboardInterrupt as exc:
        unwatched = (threading.current_thread() is threading.main_thread()
                     and signal.getsignal(signal.SIGINT) is signal.default_int_handler)
        if _SigintWatch.count() != seen or unwatched:
            raise  # the user pressed Ctrl-C (or we cannot tell): stop the run
        return _failure(exc), True
    except (Exception, SystemExit) as exc:  # the objective is user code: record what it raised and go on
        return _failure(exc), True


def evaluate_one(objective: Any, params: dict[str, Any]) -> EvalRecord:
    """Call the objective once, turning any exception or non-finite result into a failed record.

    A :class:`TimedObjective` runs the call in a child process that is killed after its timeout.
    """
    t0 = time.perf_counter()
    if isinstance(objective, TimedObjective) and objective.timeout_s:
        ev, raised = objective.call_with_timeout(params)
    elif isinstance(objective, SeededCall) and isinstance(objective.objective, TimedObjective) \
            and objective.objective.timeout_s:  # (params, seed) items of the run loop
        timed = objective.objective
        ev, raised = timed.call_with_timeout(params, call=SeededCall(timed.objective))
    else:
        ev, raised = _call(objective, params)
    if ev.status == "ok" and not math.isfinite(ev.fitness):  # pragma: no cover - as_evaluation handles
        ev = Evaluation.failed(f"non-finite fitness {ev.fitness}")
    return EvalRecord(ev, time.perf_counter() - t0, f"{os.getpid()}", raised)


class TimedObjective:
    """An objective whose evaluations stop after ``timeout_s`` seconds (``objective.timeout_s``).

    Each evaluation runs in a forked child process of the worker (or of the driver, with the
    serial backend): a child that does not answer in time is killed, the evaluation is a recorded
    failure ``timeout: no result after ... s``, and the next evaluation gets a fresh child. A thread
    could not be stopped and would keep burning a core; a child process can. The child inherits the
    objective's loaded state (the parent loads it once, through its ``preflight`` hook, before the
    first fork), and its result travels back pickled, so fitness values are the ones an in-process
    call returns. Every hook of the wrapped objective is reachable on this object.
    """

    def __init__(self, objective: Any, timeout_s: float):
        self.objective = objective
        self.timeout_s = float(timeout_s)
        self._prepared = False

    def __getstate__(self) -> dict[str, Any]:
        return {"objective": self.objective, "timeout_s": self.timeout_s}

    def __setstate__(self, d: dict[str, Any]) -> None:
        self.objective, self.timeout_s, self._prepared = d["objective"], d["timeout_s"], False

    def __getattr__(self, name: str) -> Any:
        if name in ("objective", "timeout_s", "_prepared") or name.startswith("__"):
            raise AttributeError(name)
        return getattr(self.objective, name)

    def __call__(self, params: dict[str, Any]) -> Any:
        return self.objective(params)

    def load_once(self) -> None:
        """Load the data once in this process (``preflight`` hook), so every forked child inherits it."""
        if not self._prepared:
            self._prepared = True
            prep = getattr(self.objective, "preflight", None)
            if callable(prep):
                try:
                    prep()
                except Exception:  # pragma: no cover - the driver's preflight reported it already
                    pass

    def call_with_timeout(self, params: Any, call: Any = None) -> tuple[Evaluation, bool]:
        """Evaluate ``(call or self.objective)(params)`` in a forked child killed after ``timeout_s``."""
        self.load_once()
        child, recv = fork_child(_child, call or self.objective, params)
        try:
            if recv.poll(self.timeout_s):
                try:
                    ev, raised = recv.recv()
                except EOFError:
                    ev, raised = None, True
            else:
                ev, raised = Evaluation.failed(f"timeout: no result after {self.timeout_s:g} s "
                                               "(objective.timeout_s); its process was killed"), True
        finally:
            if child.is_alive():
                child.kill()
            child.join()
            recv.close()
        if ev is None:
            ev = Evaluation.failed(f"the evaluation process died (exit code {child.exitcode})")
        return ev, raised


def fork_child(target: Any, *args: Any) -> tuple[Any, Any]:
    """Start ``target(*args, send)`` in a forked daemon process: ``(process, recv)``, ``recv`` the read
    end of a one-way pipe whose write end ``send`` only the child holds (EOF when it dies)."""
    import multiprocessing as mp

    ctx = mp.get_context("fork")
    recv, send = ctx.Pipe(duplex=False)
    child = ctx.Process(target=target, args=(*args, send), daemon=True)
    child.start()
    send.close()
    return child, recv


def _child(objective: Any, params: dict[str, Any], send: Any) -> None:
    """In the forked child: evaluate and send (evaluation, raised) back; never return to the caller."""
    code = 0
    try:
        signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C is the parent's business
        try:
            out = _call(objective, params)
        except BaseException as exc:  # pragma: no cover - _call records everything but Ctrl-C
            out = (_failure(exc), True)
        send.send(out)
    except BaseException:  # pragma: no cover
        code = 1
    finally:
        os._exit(code)


def _batch_child(fn: Any, args: tuple, send: Any) -> None:
    """In a forked child: send ``(True, fn(*args))`` or ``(False, why)``; never return to the caller."""
    code = 0
    try:
        signal.signal(signal.SIGINT, signal.SIG_IGN)
        try:
            out = (True, fn(*args))
        except BaseException as exc:
            out = (False, f"{type(exc).__name__}: {exc}")
        send.send(out)
    except BaseException:  # pragma: no cover
        code = 1
    finally:
        os._exit(code)


def _in_child(fn: Any, args: tuple, timeout_s: float) -> tuple[bool, Any]:
    """``fn(*args)`` in a forked child killed after ``timeout_s``: ``(True, value)`` or ``(False, why)``."""
    child, recv = fork_child(_batch_child, fn, args)
    try:
        if not recv.poll(timeout_s):
            return False, f"no result after {timeout_s:g} s"
        try:
            return recv.recv()
        except EOFError:
            return False, "the evaluation process died"
    finally:
        if child.is_alive():
            child.kill()
        child.join()
        recv.close()


def _batch_records(batch: Any, params: list[dict[str, Any]], n_threads: int,
                   seeds: list[int] | None) -> list[tuple[Evaluation, bool]] | None:
    """The hook's results as ``(evaluation, raised)`` pairs (None when it cannot batch this objective)."""
    out = batch(params, n_threads) if seeds is None else batch(params, n_threads, seeds=seeds)
    if out is None:
        return None
    out = list(out)
    if len(out) != len(params):
        raise RuntimeError(f"evaluate_batch returned {len(out)} results for {len(params)} candidates")
    return [(_failure(v), True) if isinstance(v, BaseException) else (as_evaluation(v), False) for v in out]


def _eval_chunk(token: str, objective: Any, chunk: list[dict[str, Any]]) -> list[EvalRecord]:
    """Worker side: reuse this process's first copy of the objective (its lazy state survives)."""
    obj = _WORKER_CACHE.get(token)
    if obj is None:
        _WORKER_CACHE.clear()  # a new run in a reused worker: drop the previous objective
        _WORKER_CACHE[token] = obj = objective
    _SigintWatch.install()
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
    backend : {"serial", "loky", "dask", "threads"}
        ``serial`` is a plain loop in this process (the debugging path); ``loky`` uses joblib's
        process pool; ``dask`` uses a ``distributed`` client: ``address`` of a running scheduler, or a
        LocalCluster of ``n_jobs`` single-threaded worker processes on 127.0.0.1; ``threads`` hands the
        whole batch to the objective's ``evaluate_batch`` hook in this process (``n_jobs`` threads),
        serial for an objective without it.
    n_jobs : int
        Worker processes for loky and the local Dask cluster, threads for ``threads`` (default 2).
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
        self.connect_timeout_s = 30.0  # set by the run from parallel.connect_timeout_s
        self.chunks_per_worker = int(chunks_per_worker)
        self.token = uuid.uuid4().hex
        self._parallel = None
        self._client = None
        self._cluster = None
        self._remote_obj = None
        #: one-line notes about this evaluator's choices (fallbacks), each printed once to stderr
        self.notes: list[str] = []
        self._prepared = False

    # --- lifecycle ----------------------------------------------------------------------------
    def __enter__(self) -> Evaluator:
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()

    def close(self) -> None:
        # this process's copy of the objective goes with the evaluator (what it holds, e.g. an FMU's extraction
        # folder, is released now, not at the next run); a worker drops its copy at its next run or its exit
        _WORKER_CACHE.pop(self.token, None)
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
        if self.backend == "threads":
            return f"threads, {self.n_jobs} in this process (objective's evaluate_batch)"
        return f"dask, {self.address or f'LocalCluster({self.n_jobs} workers)'}"

    # --- mapping ------------------------------------------------------------------------------
    def __call__(self, params_list: list[dict[str, Any]]) -> list[EvalRecord]:
        if not params_list:
            return []
        if self.backend == "serial":
            return _eval_chunk(self.token, self.objective, list(params_list))
        if self.backend == "threads":
            return self._run_threads(list(params_list))
        chunks = _chunks(list(params_list), self.n_jobs * self.chunks_per_worker)
        if self.backend == "loky":
            results = self._run_loky(chunks)
        else:
            results = self._run_dask(chunks)
        return [r for chunk in results for r in chunk]

    def _note(self, text: str) -> None:
        if text not in self.notes:
            self.notes.append(text)
            print(f"note: {text}", file=sys.stderr, flush=True)

    def _run_threads(self, items: list[Any]) -> list[EvalRecord]:
        """The whole batch through ``evaluate_batch`` (see the module docstring); serial without it."""
        seeded = isinstance(self.objective, SeededCall)
        inner = self.objective.objective if seeded else self.objective
        timed = inner if isinstance(inner, TimedObjective) and inner.timeout_s else None
        batch = hook(inner, "evaluate_batch")
        if batch is None:
            self._note(f"backend threads: {type(getattr(inner, 'objective', inner)).__name__} has no "
                       "evaluate_batch hook; its candidates are evaluated serially")
            return _eval_chunk(self.token, self.objective, items)
        params = [it[0] for it in items] if seeded else items
        seeds = [int(it[1]) for it in items] if seeded and getattr(inner, "takes_seed", False) else None
        t0 = time.perf_counter()
        try:
            if timed is None:
                recs = _batch_records(batch, params, self.n_jobs, seeds)
            else:
                if not self._prepared:  # data loaded and kernels compiled here, inherited by every child
                    self._prepared = True
                    timed.load_once()
                    batch([], self.n_jobs)
                rounds = -(-len(params) // self.n_jobs)
                ok, recs = _in_child(_batch_records, (batch, params, self.n_jobs, seeds), timed.timeout_s * rounds)
                if not ok:
                    self._note(f"backend threads: a batch gave {recs} ({rounds} x objective.timeout_s); its "
                               "candidates were re-run one at a time with their own timeout")
                    return _eval_chunk(self.token, self.objective, items)
        except Exception as exc:  # the hook itself failed: the serial path still scores every candidate
            self._note(f"backend threads: evaluate_batch raised {type(exc).__name__}: {exc}; that batch was "
                       "evaluated serially")
            return _eval_chunk(self.token, self.objective, items)
        if recs is None:
            self._note(f"backend threads: {type(getattr(inner, 'objective', inner)).__name__} cannot batch this "
                       "configuration; its candidates are evaluated serially")
            return _eval_chunk(self.token, self.objective, items)
        # per-candidate time is not observable inside one kernel: each gets its share of the batch's
        # thread-seconds, so the seconds column still sums to the work done
        share = (time.perf_counter() - t0) * min(self.n_jobs, len(params)) / len(params)
        worker = f"{os.getpid()}"
        return [EvalRecord(ev, share, worker, raised) for ev, raised in recs]

    def _pool(self):
        from joblib import Parallel

        if self._parallel is None:
            self._parallel = Parallel(n_jobs=self.n_jobs, backend="loky", batch_size=1)
            self._parallel.__enter__()
        return self._parallel

    def _run_loky(self, chunks: list[list[dict]]) -> list[list[EvalRecord]]:
        from joblib import delayed
        from joblib.externals.loky.process_executor import TerminatedWorkerError

        try:
            return self._pool()(delayed(_eval_chunk)(self.token, self.objective, c) for c in chunks)
        except TerminatedWorkerError:
            pass
        # a worker died (segfault, os._exit, out of memory): find the culprits one candidate at a time
        # in fresh workers; they become recorded failures, every other candidate gets its real result
        out = []
        for chunk in chunks:
            recs = []
            for p in chunk:
                try:
                    recs += self._pool()([delayed(_eval_chunk)(self.token, self.objective, [p])])[0]
                except TerminatedWorkerError as exc:
                    why = str(exc).split("\n")[0][:200]
                    recs.append(EvalRecord(Evaluation.failed(f"worker process died: {why}"), 0.0, "", True))
            out.append(recs)
        return out

    def _run_dask(self, chunks: list[list[dict]]) -> list[list[EvalRecord]]:
        if self._client is None:
            try:
                from distributed import Client, LocalCluster
            except ImportError:
                raise RuntimeError(
                    "parallel.backend: dask needs the 'distributed' package: pip install -e '.[cluster]' (in a clone)"
                ) from None
            if self.address:
                self._client = Client(self.address, timeout=f"{self.connect_timeout_s:g}s")
            else:
                self._cluster = LocalCluster(n_workers=self.n_jobs, threads_per_worker=1, processes=True,
                                             host="127.0.0.1", dashboard_address=None)
                self._client = Client(self._cluster)
            # ship the objective once to every worker; tasks refer to it by future
            self._remote_obj = self._client.scatter(self.objective, broadcast=True, hash=False)
        futures = [self._client.submit(_eval_chunk, self.token, self._remote_obj, c, pure=False) for c in chunks]
        return self._client.gather(futures)
