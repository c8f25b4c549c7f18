"""Shared pieces of the benchmarks: machine facts, timing, peer imports, result files."""

from __future__ import annotations

import contextlib
import importlib
import json
import math
import os
import platform
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import numpy as np

__all__ = ["RESULTS_DIR", "PEERS", "machine_facts", "peer", "scratch_cwd", "median_rate", "best_cpu_rate",
           "write_result", "fmt", "md_table"]

RESULTS_DIR = Path(__file__).resolve().parent / "results"

#: peer libraries measured side by side (import name -> pip name); none is a dependency of tuner
PEERS = {"ahrs": "ahrs", "imufusion": "imufusion", "vqf": "vqf", "pyswarms": "pyswarms", "optuna": "optuna"}


@contextlib.contextmanager
def scratch_cwd() -> Iterator[None]:
    """Run the block in a temporary working directory, then return to the one before.

    pyswarms opens ``report.log`` in the working directory when it is imported and again whenever it
    builds an optimiser (each of its ``Reporter`` objects configures a file handler there); peers run in
    here leave no stray file in the checkout. The benchmarks' objectives use absolute paths only."""
    cwd = os.getcwd()
    with tempfile.TemporaryDirectory() as d:
        os.chdir(d)
        try:
            yield
        finally:
            os.chdir(cwd)


def peer(name: str) -> Any | None:
    """Import a peer library (in :func:`scratch_cwd`), or None when it is not installed (the benchmark
    then reports it missing)."""
    if name in sys.modules:
        return sys.modules[name]
    with scratch_cwd():
        try:
            return importlib.import_module(name)
        except ImportError:
            return None


def _version(mod: str) -> str | None:
    try:
        from importlib.metadata import version

        return version(mod)
    except Exception:
        return None


def _cpu_model() -> str:
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "unknown"


def _git_commit() -> str:
    try:
        return subprocess.run(["git", "rev-parse", "HEAD"], capture_output=True, text=True, timeout=5,
                              cwd=Path(__file__).resolve().parent).stdout.strip()
    except Exception:
        return ""


def machine_facts() -> dict[str, Any]:
    """CPU, cores, load, Python and package versions: what a reader needs to compare two result files."""
    pkgs = ["numpy", "scipy", "numba", "joblib", "cma", "AHRS", "imufusion", "vqf", "pyswarms", "optuna", "psutil"]
    return {
        "cpu": _cpu_model(),
        "cores": os.cpu_count(),
        "load_avg_1_5_15": list(os.getloadavg()) if hasattr(os, "getloadavg") else None,
        "platform": platform.platform(),
        "python": sys.version.split()[0],
        "versions": {p: _version(p) for p in pkgs},
        "git_commit": _git_commit(),
        "utc": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
    }


def median_rate(fn: Callable[[], Any], n: int, repeats: int, min_time: float = 0.0) -> dict[str, float]:
    """Samples per second of ``fn`` (which processes ``n`` samples): first call timed apart (compile or
    cache load), then the median of ``repeats`` timed calls. ``min_time`` repeats until that many
    seconds have been spent (for very short calls)."""
    t = time.perf_counter()
    fn()
    first = time.perf_counter() - t
    times: list[float] = []
    spent = 0.0
    while len(times) < repeats or spent < min_time:
        t = time.perf_counter()
        fn()
        dt = time.perf_counter() - t
        times.append(dt)
        spent += dt
        if len(times) > 1000:
            break
    med = float(np.median(times))
    return {"rate": n / med, "seconds": med, "first_call_s": first, "runs": len(times), "samples": n}


def best_cpu_rate(fn: Callable[[], Any], n: int, repeats: int) -> dict[str, float]:
    """Samples per second of ``fn`` (which processes ``n`` samples, on this one thread) from its fastest of
    ``repeats`` calls in CPU time of this thread (``time.thread_time``) after a first call timed apart: on a shared
    machine the time another process holds the core is not counted, so rates measured under load stay comparable
    (a wall-clock median mostly measures the other processes)."""
    t = time.perf_counter()
    fn()
    first = time.perf_counter() - t
    best = float("inf")
    for _ in range(max(1, repeats)):
        t = time.thread_time()
        fn()
        best = min(best, time.thread_time() - t)
    best = max(best, 1e-9)
    return {"rate": n / best, "seconds": best, "first_call_s": first, "runs": max(1, repeats), "samples": n,
            "clock": "thread CPU time, best of runs"}


def _plain(v: Any) -> Any:
    """JSON-native values; non-finite floats become None ("not reached/failed": JSON has no inf/NaN)."""
    from tuner.rundir import plain

    return _finite_or_none(plain(v))


def _finite_or_none(v: Any) -> Any:
    if isinstance(v, dict):
        return {k: _finite_or_none(x) for k, x in v.items()}
    if isinstance(v, list):
        return [_finite_or_none(x) for x in v]
    if isinstance(v, float) and not math.isfinite(v):
        return None
    return v


def write_result(name: str, payload: dict[str, Any], out_dir: Path = RESULTS_DIR) -> Path:
    """``<out_dir>/<name>.json`` with the machine facts added (non-finite numbers become null)."""
    out_dir.mkdir(parents=True, exist_ok=True)
    data = {"benchmark": name, "machine": machine_facts(), **payload}
    path = out_dir / f"{name}.json"
    tmp = path.with_suffix(".json.tmp")
    tmp.write_text(json.dumps(_plain(data), indent=1, allow_nan=False))
    tmp.replace(path)
    return path



def run_alone(name: str, run: Any) -> None:
    """``python -m benchmarks.<name> [--smoke]``: ``run(smoke=...)`` timed, its result written to ``<name>.json``
    (a full run; SUMMARY.md untouched), its markdown printed; exit 0 when every target passes, else 1."""
    import sys
    import time

    smoke = "--smoke" in sys.argv
    t0 = time.perf_counter()
    res = run(smoke=smoke)
    res["seconds"] = time.perf_counter() - t0
    if not smoke:
        write_result(name, {"mode": "full", **res})
    print(res["markdown"])
    sys.exit(0 if all(t["pass"] for t in res["targets"]) else 1)

def fmt(v: Any, digits: int = 3) -> str:
    """Compact number for tables (None/inf/NaN as a dash)."""
    if v is None:
        return "-"
    if isinstance(v, str):
        return v
    if isinstance(v, (bool, np.bool_)):
        return "yes" if v else "no"
    v = float(v)
    if not math.isfinite(v):
        return "-"
    if v != 0 and (abs(v) >= 1e6 or abs(v) < 1e-3):
        return f"{v:.{digits - 1}e}"
    if abs(v) >= 100:
        return f"{v:,.0f}"
    return f"{v:.{digits}g}"


def md_table(header: list[str], rows: list[list[Any]]) -> str:
    """A Markdown table (cells formatted with :func:`fmt`)."""
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    for r in rows:
        lines.append("| " + " | ".join(fmt(c) for c in r) + " |")
    return "\n".join(lines)
