"""Why evaluations failed, grouped by what failed rather than by their exact text.

An error text may give several reasons separated by ``"; "`` (a closed loop names every violated
requirement, each with its value). Counting whole texts would count each value apart: 139 evaluations
that miss an overshoot limit by different amounts give 139 texts, and the one reason that repeats
verbatim (a settling time of ``inf``) looked the most frequent. :func:`failure_groups` counts each reason
under its text with the numbers masked (``overshoot # % > # % (max_overshoot_pct)``), once per
evaluation, so a count is the number of failed evaluations that give that reason, and keeps the first
text of each group as its example.
"""

from __future__ import annotations

import re
from collections.abc import Iterable
from dataclasses import dataclass

__all__ = ["FailureGroup", "failure_groups", "reason_key", "SEPARATOR"]

#: what separates the reasons of one error text
SEPARATOR = "; "
_NUMBER = re.compile(r"(?<![A-Za-z0-9_.+-])[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?(?![A-Za-z_])"
                     r"|\b(?:-?inf|nan)\b")


@dataclass(frozen=True)
class FailureGroup:
    """One reason: its text with the numbers masked, how many failed evaluations give it, an example."""

    key: str
    count: int
    example: str


def reason_key(reason: str) -> str:
    """``reason`` with every number (and inf, nan) replaced by ``#``; a number inside a name stays."""
    return _NUMBER.sub("#", reason.strip())


def failure_groups(errors: Iterable[str]) -> list[FailureGroup]:
    """The reasons of ``errors`` (one text per failed evaluation; empty ones are skipped), most frequent
    first (ties: first seen first)."""
    counts: dict[str, int] = {}
    example: dict[str, str] = {}
    for err in errors:
        if not err:
            continue
        seen = set()
        for reason in str(err).split(SEPARATOR):
            if not reason.strip():
                continue
            k = reason_key(reason)
            if k in seen:
                continue
            seen.add(k)
            counts[k] = counts.get(k, 0) + 1
            example.setdefault(k, reason.strip())
    order = sorted(counts, key=lambda k: -counts[k])  # stable: first seen first among equals
    return [FailureGroup(k, counts[k], example[k]) for k in order]
