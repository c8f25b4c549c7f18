"""What may load code: the one rule, and the one place a config's code is loaded.

A config can name code: the module of ``objective.kind: python``, a plant's Python dynamics
(``plant: {python: module:function}``) or an FMU (a native library). Loading it runs it. The rule:

- **Read-only commands never load such code**: ``show``, ``compare``, ``export`` (every format), ``report``,
  ``dashboard``, ``list``, ``describe`` and reading a run from Python (:func:`tuner.load`) run under
  :func:`data_only`; an objective they rebuild for its units or tables is built without it (the export
  says what it left out).
- **Only the commands that run code load it**: ``run``, ``resume``, ``evaluate``, ``cv``, ``verify-c``,
  ``sweep``, ``demo`` and :meth:`tuner.Result.build` (each says which in the README's table), and then only code
  the user points at: code found inside the run directory a command was handed (a ``base_dir`` in its
  ``config.yaml`` pointing into it, a module or an FMU lying in it) is refused, :func:`code_outside`. To run
  such code on purpose, copy it out of the run directory, read it, and name it from a config of your own
  (``tuner evaluate YOUR.yaml --params RUN_DIR/best.yaml`` scores the run's best parameters with it).

The domain asks here before it loads anything a config names: :func:`import_code` for a ``module:attr``
(found without being imported, so its location is checked before it runs) and :func:`check_code` for a file
(an FMU). A refusal is a :class:`CodeRefused` (a ``ValueError`` naming the key: one ``error:`` line).

The policy is a context variable: it holds in the thread that set it and in code called from there, not in
worker processes, which only rebuild what the process that checked it has loaded.
"""

from __future__ import annotations

import importlib
import importlib.machinery
import sys
from collections.abc import Iterator
from contextlib import contextmanager
from contextvars import ContextVar
from dataclasses import dataclass
from pathlib import Path
from typing import Any

__all__ = ["CodeRefused", "Policy", "data_only", "code_outside", "check_code", "import_code", "policy"]


class CodeRefused(ValueError):
    """Code a config names that the current command may not load."""


@dataclass(frozen=True)
class Policy:
    """``allowed``: may code a config names be loaded at all; ``refused``: folders no code may come from (run
    directories handed to the command); ``who``: the command, for messages."""

    allowed: bool = True
    refused: tuple[Path, ...] = ()
    who: str = ""


_OPEN = Policy()
_POLICY: ContextVar[Policy | None] = ContextVar("tuner_code_policy", default=None)


def policy() -> Policy:
    """The policy in force here (outside any block: code may be loaded, as by any library)."""
    return _POLICY.get() or _OPEN


@contextmanager
def data_only(who: str) -> Iterator[None]:
    """No code a config names is loaded inside this block (a read-only command, ``who``)."""
    token = _POLICY.set(Policy(False, policy().refused, who))
    try:
        yield
    finally:
        _POLICY.reset(token)


@contextmanager
def code_outside(*dirs: str | Path | None, who: str = "") -> Iterator[None]:
    """Code may be loaded inside this block, but none from inside ``dirs`` (the run directories the command
    was handed; None entries are ignored)."""
    old = policy()
    extra = tuple(Path(d).resolve() for d in dirs if d is not None)
    token = _POLICY.set(Policy(old.allowed, old.refused + extra, who or old.who))
    try:
        yield
    finally:
        _POLICY.reset(token)


def _inside(path: Path, folder: Path) -> bool:
    return path == folder or folder in path.parents


def check_code(path: str | Path, key: str, what: str = "code") -> None:
    """:class:`CodeRefused` unless the current policy lets ``path`` (a module's file or folder, an FMU) be
    loaded; ``key`` is the config key that names it, ``what`` says what it is."""
    p = policy()
    if not p.allowed:
        raise CodeRefused(f"{key}: names {what} ({path}), which `{p.who or 'this command'}` does not load: a "
                          "read-only command reads a run as data and never runs the code its config names")
    resolved = Path(path).resolve()
    for folder in p.refused:
        if _inside(resolved, folder):
            raise CodeRefused(f"{key}: {what} {resolved} lies inside the run directory {folder}; tuner loads no "
                              "code shipped with a run. To run it, copy it out, read it, and name it from a config "
                              f"of your own (e.g. tuner evaluate YOUR.yaml --params {folder}/best.yaml)")


def _locate(module: str, base_dir: Path | None) -> Path | None:
    """Where ``module``'s top-level package or module would be imported from (no code runs), or None when it
    is a built-in, frozen or not found."""
    top = module.split(".")[0]
    loaded = sys.modules.get(top)
    if loaded is not None:
        f = getattr(loaded, "__file__", None)
        return Path(f) if f else None
    path = ([str(base_dir)] if base_dir is not None else []) + sys.path
    spec = importlib.machinery.PathFinder.find_spec(top, path)
    if spec is None:
        return None
    if spec.origin and spec.origin not in ("built-in", "frozen", "namespace"):
        return Path(spec.origin)
    locs = list(spec.submodule_search_locations or [])
    return Path(locs[0]) if locs else None


def import_code(spec: str, base_dir: str | Path | None, key: str) -> Any:
    """``"package.module:attr.sub"`` imported (``base_dir``, a config's folder, searched first) and its
    attribute returned, after :func:`check_code` allowed where it comes from. ``ImportError`` or
    ``AttributeError`` when it does not exist, :class:`CodeRefused` when the policy forbids it."""
    module, _, attr = spec.partition(":")
    base = Path(base_dir).resolve() if base_dir is not None else None
    p = policy()
    if not p.allowed:
        check_code(spec, key, "Python code")
    if base is not None:
        for folder in p.refused:  # the folder searched first must not be a handed-over run's
            if _inside(base, folder):
                check_code(base, key, "the folder searched for its module")
    where = _locate(module, base)
    if where is not None:
        check_code(where, key, f"the module of {spec!r}")
    from tuner.registry import resolve_callable

    return resolve_callable(spec, base)
