"""A candidate whose controller cannot be designed: the one failed evaluation every closed loop gives it.

A design can fail for a candidate's values (a Riccati equation without solution, a gain schedule out of
reach): the controller's coefficients then raise ``ValueError``. That candidate is a failed evaluation
``controller design failed: <why>`` (:func:`failed_design`), the same in a serial run, in a population kernel's
batch and in a report's score of the start and the tuned values (:func:`evaluate_loop`).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from tuner.objective import Evaluation

__all__ = ["failed_design", "evaluate_loop"]


def failed_design(exc: ValueError) -> Evaluation:
    """The failed evaluation of a candidate whose design raised ``exc``."""
    return Evaluation.failed(f"controller design failed: {exc}")


def evaluate_loop(loop: Any, params: Mapping[str, Any] | None) -> Evaluation:
    """``loop.evaluate(params)`` (any plant family's loop), or :func:`failed_design` when the design cannot be
    built: the closed-loop objective's evaluation of ``params``."""
    try:
        return loop.evaluate(params)
    except ValueError as exc:
        return failed_design(exc)
