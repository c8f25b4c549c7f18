"""YAML with bounds: every YAML tuner reads (configs, sweep files, ``best.yaml``, a run's ``config.yaml``,
``--params``, ``--data``) goes through :func:`load`.

PyYAML's safe loader builds no objects from tags, but it still accepts a "billion laughs" document
(ten aliases of ten aliases ... : a few hundred bytes that expand to gigabytes when the config is copied,
hashed or written out) and nesting deep enough to overflow the interpreter's stack. Here aliases are
limited to :data:`MAX_ALIASES` per document and the expanded document to :data:`MAX_NODES`
values, nesting to :data:`MAX_DEPTH`, and the text to
:data:`MAX_BYTES`; each is a :class:`YAMLLimit` (a ``yaml.YAMLError``), and :func:`one_line` turns any
YAML error into one short line with its position.
"""

from __future__ import annotations

from typing import Any

import yaml
from yaml.events import AliasEvent

__all__ = ["load", "one_line", "YAMLLimit", "MAX_ALIASES", "MAX_DEPTH", "MAX_BYTES"]

MAX_ALIASES = 100
MAX_DEPTH = 64
MAX_BYTES = 16 * 2**20
MAX_NODES = 1_000_000


class YAMLLimit(yaml.YAMLError):
    pass


class _BoundedLoader(yaml.SafeLoader):
    def __init__(self, stream: Any):
        super().__init__(stream)
        self._aliases = 0
        self._depth = 0

    def compose_node(self, parent: Any, index: Any) -> Any:
        if self.check_event(AliasEvent):
            self._aliases += 1
            if self._aliases > MAX_ALIASES:
                raise YAMLLimit(f"more than {MAX_ALIASES} aliases (*name) in one document; refused (an alias bomb?)")
        self._depth += 1
        try:
            if self._depth > MAX_DEPTH:
                raise YAMLLimit(f"nested deeper than {MAX_DEPTH} levels; refused")
            return super().compose_node(parent, index)
        finally:
            self._depth -= 1


def _expanded_size(node: Any, memo: dict[int, int]) -> int:
    """Values the document holds once every alias is expanded (memoised per node: linear time)."""
    key = id(node)
    if key not in memo:
        memo[key] = 0  # a recursive alias counts once
        if isinstance(node, yaml.SequenceNode):
            memo[key] = 1 + sum(_expanded_size(c, memo) for c in node.value)
        elif isinstance(node, yaml.MappingNode):
            memo[key] = 1 + sum(_expanded_size(k, memo) + _expanded_size(v, memo) for k, v in node.value)
        else:
            if "\x00" in str(node.value):
                raise YAMLLimit(f"a NUL byte in a value at line {node.start_mark.line + 1}; refused (not a valid "
                                "name, path or text)")
            memo[key] = 1
        memo[key] = min(memo[key], MAX_NODES + 1)
    return memo[key]


def load(text: str | bytes) -> Any:
    """``yaml.safe_load`` within the limits above (``yaml.YAMLError`` otherwise)."""
    if len(text) > MAX_BYTES:
        raise YAMLLimit(f"larger than {MAX_BYTES // 2**20} MiB; refused")
    loader = _BoundedLoader(text)
    try:
        node = loader.get_single_node()
        if node is None:
            return None
        if _expanded_size(node, {}) > MAX_NODES:
            raise YAMLLimit(f"expands to more than {MAX_NODES} values through its aliases; refused (an alias bomb?)")
        return loader.construct_document(node)
    except RecursionError:
        raise YAMLLimit("nested too deeply; refused") from None
    finally:
        loader.dispose()


def one_line(exc: Exception) -> str:
    """A YAML error as one short line: what is wrong and where (``line L, column C``)."""
    if isinstance(exc, yaml.MarkedYAMLError):
        mark = exc.problem_mark or exc.context_mark
        where = f" at line {mark.line + 1}, column {mark.column + 1}" if mark is not None else ""
        what = exc.problem or exc.context or "syntax error"
        return f"{what}{where}"
    return " ".join(str(exc).split())[:300]
