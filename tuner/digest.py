"""The digest chain of ``history.csv``: ``history.chain`` holds for every row a hash of its cells and of the
digest of the row before it; the first row's predecessor is the run's config hash (``meta.json``).

Editing any recorded cell (a fitness, a status, a parameter, an error text), deleting, inserting or
reordering rows breaks the chain at that row, which ``resume``, ``show`` and ``report`` name and refuse.
The ``seconds`` column is left out (wall time, the one cell that differs between serial, parallel and
resumed runs of the same config and seed), and the digests live beside the history, not in it, so that
histories of runs whose configs differ only in how they ran (backend, workers) stay equal. Empty cells are
left out too, so a metric column added later (the header grows) does not change earlier rows' digests.

This detects edits by hand and corruption; it is not a signature: someone who recomputes the chain on
purpose can still forge a history (the code is public and no secret is involved).
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Mapping
from typing import Any

__all__ = ["row_digest", "parse_chain", "first_mismatch"]

CHAIN = "history.chain"
_SKIP = frozenset({"seconds"})


def _cell(v: Any) -> str:
    return "" if v is None else str(v)


def row_digest(previous: str, row: Mapping[str, Any]) -> str:
    """The digest of ``row`` (cells as written to the CSV) chained to ``previous`` (32 hex digits)."""
    cells = sorted((str(k), _cell(v)) for k, v in row.items() if k not in _SKIP and k is not None and _cell(v) != "")
    h = hashlib.sha256(previous.encode())
    h.update(json.dumps(cells, ensure_ascii=False, separators=(",", ":")).encode())
    return h.hexdigest()[:32]


def parse_chain(text: str) -> list[tuple[str, str]]:
    """``history.chain``'s ``eval,digest`` lines; a torn (short) last line is left out."""
    out = []
    for ln in text.split("\n"):
        e, _, d = ln.partition(",")
        if len(d) == 32:
            out.append((e, d))
    return out


def first_mismatch(rows: list[Mapping[str, Any]], digests: list[tuple[str, str]],
                   config_hash: str) -> tuple[str, str] | None:
    """``(eval, what is wrong)`` of the first row without its chained digest, or None when all match."""
    prev = config_hash
    for i, row in enumerate(rows):
        d = row_digest(prev, row)
        if i >= len(digests):
            return str(row.get("eval", i)), "has no digest in history.chain"
        if digests[i] != (str(row.get("eval")), d):
            return str(row.get("eval", i)), ("does not match its digest in history.chain (chained to the rows "
                                             "before it and to the config)")
        prev = d
    return None
