"""Stop signals: Ctrl-C (SIGINT), SIGTERM and SIGHUP all stop tuner the same way.

Batch schedulers (SLURM, systemd, a container stop) send SIGTERM before they kill; a closed terminal
sends SIGHUP. Each of them is counted and raised as ``KeyboardInterrupt`` in the main thread, which is a
``BaseException``: an objective's ``except Exception`` does not swallow it, the evaluators tell it apart
from an objective's own ``KeyboardInterrupt`` by the count (see :func:`tuner.evaluate._call`), and a run
ends ``interrupted`` with the generation in progress not recorded, exactly as after a Ctrl-C.

A signal set to be ignored (``nohup`` ignores SIGHUP) stays ignored; only the default action (terminate
at once, leaving ``meta.json`` at ``running``) is replaced.
"""

from __future__ import annotations

import signal
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

__all__ = ["STOP_SIGNALS", "count", "install", "stop_signals"]

STOP_SIGNALS = tuple(getattr(signal, n) for n in ("SIGTERM", "SIGHUP") if hasattr(signal, n))


class _Count:
    n = 0


def _handler(signum: int, frame: Any) -> None:
    _Count.n += 1
    raise KeyboardInterrupt


def count() -> int:
    """Stop signals (SIGINT included) counted by this module's handler so far in this process."""
    return _Count.n


def is_handler(h: Any) -> bool:
    return h is _handler


def install(sigint: bool = True, others: bool = True) -> dict[int, Any]:
    """Install the counting handler (main thread only); return the handlers it replaced.

    SIGINT is taken over only from Python's default handler; SIGTERM and SIGHUP only from ``SIG_DFL``.
    """
    if threading.current_thread() is not threading.main_thread():
        return {}
    old: dict[int, Any] = {}
    if sigint and signal.getsignal(signal.SIGINT) is signal.default_int_handler:
        old[signal.SIGINT] = signal.signal(signal.SIGINT, _handler)
    if others:
        for sig in STOP_SIGNALS:
            if signal.getsignal(sig) == signal.SIG_DFL:
                old[sig] = signal.signal(sig, _handler)
    return old


def restore(old: dict[int, Any]) -> None:
    if threading.current_thread() is not threading.main_thread():
        return
    for sig, h in old.items():
        signal.signal(sig, h)


@contextmanager
def stop_signals() -> Iterator[None]:
    """SIGTERM and SIGHUP (and Ctrl-C) raise a counted ``KeyboardInterrupt`` inside the block."""
    old = install()
    try:
        yield
    finally:
        restore(old)
