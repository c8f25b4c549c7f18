"""The digest chain of ``history.csv``: ``history.chain`` holds for every row a hash of its cells and of the
digest of the row before it; the first row's predecessor is the run's config hash (``meta.json``).

Editing any recorded cell (a fitness, a status, a parameter, an error text), deleting, inserting or
reordering rows breaks the chain at that row, which ``resume``, ``show`` and ``report`` name and refuse; a
history without its ``history.chain`` is refused too. The ``seconds`` column is left out (wall time, the one
cell that differs between serial, parallel and resumed runs of the same config and seed), and the digests live
beside the history, not in it, so that histories of runs whose configs differ only in how they ran (backend,
workers) stay equal. Empty cells are left out too, so a metric column added later (the header grows) does not
change earlier rows' digests.

What it proves. An **unkeyed** chain (SHA-256, the default) catches accidents and naive edits: a cell changed
by hand, rows lost, a history copied beside another run's config. It is not a signature: the code is public
and no secret is involved, so anyone who edits a history on purpose can recompute its chain.

A **keyed** chain (HMAC-SHA-256 with a secret of the user's, for those who exchange runs) is written when a
key is set: the environment variable ``TUNER_CHAIN_KEY`` (the key itself), else the file
``$XDG_CONFIG_HOME/tuner/chain.key`` (``~/.config/tuner/chain.key``), never a file of the run directory.
Whoever holds the key can then check that a history was written by a holder of the key and not edited since;
without the key nobody can recompute it. The chain's first line names the key by an id (a hash of the key,
which does not reveal it): reading a keyed chain needs that key, and a different or missing one is an error.
Share the key as any secret (a password manager, not the run directory); a chain written before the key was
set stays unkeyed, and with a key set an unkeyed chain is read with a note (anyone could have recomputed it).
"""

from __future__ import annotations

import hashlib
import hmac
import json
import os
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

__all__ = ["CHAIN", "KEY_ENV", "Chain", "ChainKey", "ChainKeyError", "row_digest", "parse_chain", "first_mismatch",
           "chain_key", "key_file", "key_for", "MIN_KEY_CHARS"]

CHAIN = "history.chain"
#: the environment variable holding the chain key itself (wins over the key file)
KEY_ENV = "TUNER_CHAIN_KEY"
#: the shortest key accepted (characters; 64 hex digits of ``secrets.token_hex(32)`` is the suggestion)
MIN_KEY_CHARS = 16
_HEADER = "#hmac-sha256 key "
_SKIP = frozenset({"seconds"})


class ChainKeyError(ValueError):
    """A keyed chain without its key, with another key, or a key that is not usable."""


@dataclass(frozen=True)
class ChainKey:
    """The user's chain key: the secret, its public id and where it was read from."""

    secret: bytes = field(repr=False)
    id: str
    source: str


@dataclass(frozen=True)
class Chain:
    """A parsed ``history.chain``: the id of the key it is keyed with (None: unkeyed) and its
    ``(eval, digest)`` lines."""

    key_id: str | None
    digests: list[tuple[str, str]]

    def text(self, digests: list[tuple[str, str]] | None = None) -> str:
        """The file's text with ``digests`` (default: its own)."""
        head = f"{_HEADER}{self.key_id}\n" if self.key_id else ""
        return head + "".join(f"{e},{d}\n" for e, d in (self.digests if digests is None else digests))


def key_file() -> Path:
    """Where the chain key is read from when ``TUNER_CHAIN_KEY`` is not set."""
    base = os.environ.get("XDG_CONFIG_HOME") or str(Path.home() / ".config")
    return Path(base) / "tuner" / "chain.key"


def chain_key() -> ChainKey | None:
    """The user's chain key (``TUNER_CHAIN_KEY``, else :func:`key_file`), or None when none is set."""
    text, source = os.environ.get(KEY_ENV, ""), f"${KEY_ENV}"
    if not text.strip():
        path = key_file()
        try:
            with open(path, "rb") as fh:  # the user's own file, outside any run directory
                raw = fh.read(4097)
        except FileNotFoundError:
            return None
        except OSError as exc:
            raise ChainKeyError(f"{path}: the history chain key cannot be read: {exc.strerror or exc}") from None
        if len(raw) > 4096:
            raise ChainKeyError(f"{path}: the history chain key is longer than 4096 bytes; expected one line")
        text, source = raw.decode("utf-8", errors="replace"), str(path)
    secret = text.strip().encode()
    if len(secret) < MIN_KEY_CHARS:
        raise ChainKeyError(f"{source}: the history chain key is shorter than {MIN_KEY_CHARS} characters; make one "
                            "with: python -c 'import secrets; print(secrets.token_hex(32))'")
    return ChainKey(secret, hashlib.sha256(b"tuner-chain-key-id\0" + secret).hexdigest()[:12], source)


def key_for(chain: Chain, where: Any) -> bytes | None:
    """The secret a chain is keyed with (None for an unkeyed chain); :class:`ChainKeyError` when the user's key
    is missing or another one."""
    if chain.key_id is None:
        return None
    key = chain_key()
    if key is None:
        raise ChainKeyError(f"{where}: keyed with the chain key {chain.key_id}, and no key is set: set {KEY_ENV} or "
                            f"{key_file()} to the key the run was written with to read it")
    if key.id != chain.key_id:
        raise ChainKeyError(f"{where}: keyed with the chain key {chain.key_id}, not with the key set ({key.source}, "
                            f"id {key.id}): it was written by someone else, or the key changed")
    return key.secret


def _cell(v: Any) -> str:
    return "" if v is None else str(v)


def row_digest(previous: str, row: Mapping[str, Any], key: bytes | None = None) -> str:
    """The digest of ``row`` (cells as written to the CSV) chained to ``previous`` (32 hex digits); an HMAC
    with ``key`` when given."""
    cells = sorted((str(k), _cell(v)) for k, v in row.items() if k not in _SKIP and k is not None and _cell(v) != "")
    body = json.dumps(cells, ensure_ascii=False, separators=(",", ":")).encode()
    if key is not None:
        return hmac.new(key, previous.encode() + b"\n" + body, hashlib.sha256).hexdigest()[:32]
    h = hashlib.sha256(previous.encode())
    h.update(body)
    return h.hexdigest()[:32]


def parse_chain(text: str) -> Chain:
    """``history.chain``'s key line (first, keyed chains only) and ``eval,digest`` lines; a torn (short) last
    line is left out."""
    lines = text.split("\n")
    key_id = None
    if lines and lines[0].startswith(_HEADER):
        key_id = lines.pop(0)[len(_HEADER):].strip() or None
    out = []
    for ln in lines:
        e, _, d = ln.partition(",")
        if len(d) == 32:
            out.append((e, d))
    return Chain(key_id, out)


def first_mismatch(rows: list[Mapping[str, Any]], digests: list[tuple[str, str]],
                   config_hash: str, key: bytes | None = None) -> tuple[str, str] | None:
    """``(eval, what is wrong)`` of the first row without its chained digest, or None when all match."""
    prev = config_hash
    for i, row in enumerate(rows):
        d = row_digest(prev, row, key)
        if i >= len(digests):
            return str(row.get("eval", i)), "has no digest in history.chain"
        if digests[i] != (str(row.get("eval")), d):
            return str(row.get("eval", i)), ("does not match its digest in history.chain (chained to the rows "
                                             "before it and to the config)")
        prev = d
    return None
