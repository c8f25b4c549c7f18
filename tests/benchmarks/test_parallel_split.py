"""benchmarks/parallel.py splits a backend's CPU into the calling thread's (serial) part and the rest."""

from __future__ import annotations

from benchmarks.parallel import speedup


def _fixed_work(params):
    """A fixed amount of CPU work per evaluation (not a clock wait: its CPU seconds do not depend on load)."""
    return float(sum(i * i for i in range(60_000)) % 7) + params["x0"]


def test_a_backend_that_runs_everything_in_the_calling_thread_has_serial_fraction_one():
    # no evaluate_batch hook: the threads backend evaluates in the calling thread, nothing in parallel
    # CPU seconds of the same work drift by up to ~30 % between runs on a loaded machine; a backend that
    # handed the work to other threads would leave the calling thread a fraction near 0
    r = speedup(_fixed_work, [{"x0": 0.1}] * 12, repeats=5, backends=("serial", "threads"))
    assert 0.67 < r["serial_fraction_threads"] < 1.5
    assert 0.67 < r["amdahl_bound_threads"] < 1.5
    assert r["threads_main_cpu_s"] <= r["threads_cpu_s"] + 1e-3
