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
from tuner.rundir import CHAIN, RunDir, chain_note, chain_secret, check_chain, read_chain
from tuner.safe_io import regular

__all__ = ["Replay", "verify_history"]


def verify_history(rd: RunDir) -> str:
    """Check ``history.csv`` against ``history.chain`` (:class:`RunError` naming the first edited row; a history
    without its chain, or keyed with a key not set here, is an error too).

    Rows beyond the checkpoint without a digest (a kill between the two appends) are left out. Returns a note
    when the chain is unkeyed while the user has a chain key set (:func:`tuner.rundir.chain_note`), else ''.
    """
    if not regular(rd.file("history.csv")):
        return ""
    chain = read_chain(rd.file(CHAIN))
    key = chain_secret(chain, rd.file(CHAIN))
    rows = rd.history_rows()
    ck = rd.checkpoint() if regular(rd.file("checkpoint.json")) else None
    n = max(min(len(rows), len(chain.digests)), ck.n_evals if ck else 0)
    check_chain(rd.file("history.csv"), rows[:n], chain.digests, rd.meta().config_hash, key)
    return chain_note(chain)


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
