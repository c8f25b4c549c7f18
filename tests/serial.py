"""The serial reference of a population evaluated at once (an objective's ``evaluate_batch``)."""

from __future__ import annotations

from collections.abc import Callable, Iterable
from typing import Any

__all__ = ["serial_outcomes"]


def serial_outcomes(f: Callable[[Any], Any], params_list: Iterable[Any]) -> list[Any]:
    """``f(p)`` for every ``p`` in order, or the exception that call raised: what the serial path gives each
    candidate, so what :meth:`tuner.objective.TunableObjective.evaluate_batch` must return for them."""
    out: list[Any] = []
    for p in params_list:
        try:
            out.append(f(p))
        except Exception as exc:  # handed back as the batch hands it back
            out.append(exc)
    return out
