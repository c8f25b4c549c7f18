"""Replaying a run's recorded generations on resume.

Resuming re-creates the optimiser from the run seed and hands it back the recorded results of the
first rows of ``history.csv``; each replayed candidate is checked against its row, so an edited
history (or changed code) is refused with the row named.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

from tuner.evaluate import EvalRecord
from tuner.objective import Evaluation
from tuner.records import HistoryRow, RunError, cell
from tuner.rundir import CHAIN, RunDir, check_chain, read_chain

__all__ = ["Replay", "verify_history"]


def verify_history(rd: RunDir) -> str:
    """Check ``history.csv`` against ``history.chain`` (:class:`RunError` naming the first edited row).

    Rows beyond the checkpoint without a digest (a kill between the two appends) are left out. Returns a
    note for a history of an older tuner, which has no chain (still readable), else ''.
    """
    rows = rd.history_rows()
    if not rows:
        return ""
    if not rd.file(CHAIN).exists():
        return "history.csv has no history.chain (written by an older tuner): edits to it cannot be detected"
    digests = read_chain(rd.file(CHAIN))
    ck = rd.checkpoint() if rd.file("checkpoint.json").exists() else None
    n = max(min(len(rows), len(digests)), ck.n_evals if ck else 0)
    check_chain(rd.file("history.csv"), rows[:n], digests, rd.meta().config_hash)
    return ""


class Replay:
    """Hands back the recorded results of the first rows of ``history.csv``, then evaluates live.

    Each replayed candidate is checked against its row: a row whose parameters differ from what
    the re-created optimiser asks means the history was edited (or the code changed), and is refused.
    """

    def __init__(self, rows: list[dict[str, str]], names: list[str], live: Callable, where: Path):
        self.rows, self.names, self.live, self.where = rows, names, live, where
        self.pos = 0

    @property
    def replaying(self) -> bool:
        return self.pos < len(self.rows)

    def __call__(self, fn: Callable, items: list[tuple[dict[str, Any], int]]) -> list[EvalRecord]:
        if not self.replaying:
            return self.live(fn, items)
        chunk = self.rows[self.pos:self.pos + len(items)]
        if len(chunk) != len(items):
            raise RunError(f"{self.where}: rows {self.pos}-{len(self.rows) - 1} are not a complete generation "
                           f"({len(items)} evaluations)")
        out = []
        for (params, _), row in zip(items, chunk):
            for k in self.names:
                if cell(params[k]) != row.get(k):
                    raise RunError(f"{self.where}: row eval={row.get('eval')}: {k} is {row.get(k)!r} but the "
                                   f"optimiser re-created from the seed asks {cell(params[k])!r}; the history "
                                   "was edited or the code changed, so it cannot be resumed")
            h = HistoryRow.parse(row, self.names, self.where)
            out.append(EvalRecord(Evaluation(h.fitness, h.metrics, h.status, h.error), h.seconds))
        self.pos += len(items)
        return out
