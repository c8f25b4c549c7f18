"""``tuner init NAME`` and ``tuner demo``: a starter job for a filter or controller, and the packaged jobs.

Starter jobs come from the objective packages: the entry-point group ``tuner.starters`` maps an
objective kind to ``starter(name) -> str | None`` (commented YAML, or None when the kind has no such
name), e.g. ``filter = "objectives.starters:filter_starter"``. The names ``init`` accepts are those
the kinds list under ``filters`` and ``controllers`` (``tuner list``).

The example jobs that need no shared data ship inside the package (``tuner/data/configs/``, copies of
the repository's ``configs/`` checked equal by a test), so ``tuner demo`` works after a plain
``pip install`` of the wheel, from any directory.
"""

from __future__ import annotations

import difflib
from importlib import resources
from importlib.metadata import entry_points
from pathlib import Path

__all__ = ["STARTER_GROUP", "StarterError", "starter_names", "starter_text", "write_starter", "packaged_config",
           "packaged_configs"]

STARTER_GROUP = "tuner.starters"
#: catalog sections whose names ``tuner init`` accepts
SECTIONS = ("filters", "controllers")


class StarterError(ValueError):
    """An unknown name, or a file that exists (the command line prints it as an ``error:`` line)."""


def starter_names() -> dict[str, str]:
    """``{name: kind}`` of every filter and controller the registered objective kinds list."""
    from tuner.registry import REGISTRY

    out: dict[str, str] = {}
    for kind, sections in REGISTRY.catalogs().items():
        for section in SECTIONS:
            for name in sections.get(section, []):
                out.setdefault(name, kind)
    return out


def starter_text(name: str) -> str:
    """The starter job of filter or controller ``name`` (YAML with comments).

    Raises :class:`StarterError` for an unknown name (listing close matches) or a kind that registers
    no starter.
    """
    names = starter_names()
    if name not in names:
        close = difflib.get_close_matches(name, list(names), n=3, cutoff=0.5)
        hint = f"did you mean {', '.join(repr(c) for c in close)}? " if close else ""
        raise StarterError(f"init: unknown filter or controller {name!r}; {hint}known: {', '.join(sorted(names))}")
    kind = names[name]
    for ep in entry_points(group=STARTER_GROUP):
        if ep.name == kind:
            text = ep.load()(name)
            if text:
                return text
    raise StarterError(f"init: objective kind {kind!r} (of {name!r}) registers no starter job "
                       f"(entry-point group {STARTER_GROUP})")


def write_starter(name: str, path: str | Path | None = None) -> Path:
    """Write the starter job of ``name`` to ``path`` (default ``NAME.yaml``); never overwrites a file."""
    text = starter_text(name)
    out = Path(path) if path is not None else Path(f"{name}.yaml")
    if out.exists():
        raise StarterError(f"{out}: exists; not overwritten (remove it or choose another file with -o)")
    text = text.replace(f"`tuner run {name}.yaml`", f"`tuner run {out}`")  # the header names the file written
    with open(out, "x") as fh:  # "x": a file created between the check and here is not overwritten either
        fh.write(text)
    return out


def packaged_configs() -> list[str]:
    """File names of the example jobs shipped in the package (``tuner/data/configs/``)."""
    root = resources.files("tuner") / "data" / "configs"
    return sorted(p.name for p in root.iterdir() if p.name.endswith(".yaml"))


#: the README's own-CSV example shipped in ``tuner/data/configs/examples/``: ``{job: its column map}``
OWN_DATA_EXAMPLES = {"own_csv.yaml": "imu_columns.yaml"}


def packaged_config(name: str) -> Path:
    """Path of the packaged example job ``name`` (e.g. ``demo.yaml``, or ``own_csv.yaml`` of
    :data:`OWN_DATA_EXAMPLES`); a sweep's ``base:`` files are beside it, an example's data and column map too."""
    root = resources.files("tuner") / "data" / "configs"
    path = Path(str(root / name))
    if not path.is_file() and name in OWN_DATA_EXAMPLES:
        path = Path(str(root / "examples" / name))
    if not path.is_file():
        raise StarterError(f"{name}: not a packaged job; packaged: {', '.join(packaged_configs())}")
    return path
