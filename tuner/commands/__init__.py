"""The commands of ``tuner``: one module per command, and the commands other packages add.

An engine command is a module here (``tuner/commands/run.py`` for ``tuner run``) with

- ``add_arguments(parser)``: its arguments on its ``argparse`` sub-parser (``DESCRIPTION``, if the module has
  one, is the sub-parser's description);
- ``run(args) -> int``: the command itself, returning the exit status; bad input raises
  :class:`tuner.commands.common.UsageError` (or the ``ConfigError``/``RunError`` of the code it calls),
  which :func:`tuner.cli.main` prints as one ``error:`` line with exit status 2.

:data:`ENGINE` names each command's module and its one-line help, so ``tuner --help`` lists every command
without importing any, and a command imports its module (and what that imports, at its top) only when it
runs: ``tuner show`` never pays for pandas.

A package adds commands through the entry-point group ``tuner.commands`` (:data:`ENTRY_POINT_GROUP`) of its
``pyproject.toml``::

    [project.entry-points."tuner.commands"]
    align = "objectives.attitude.align:COMMAND"

The value is an object with ``name`` (the entry point's name), ``help`` (one line), ``add_arguments(parser)``
and ``run(args) -> int`` (:class:`Command`; a module with those four names is one), and ``runs_code = True``
if it may load the code a config names (else it runs under :func:`tuner.trust.data_only`). The group is read only
when the command typed is not an engine command, and by ``tuner --help`` (which loads each object for its
help line, so such a module should import its heavy parts where ``run`` needs them). An engine command's name
is never looked up there: a package cannot replace ``tuner run``.
"""

from __future__ import annotations

import argparse
import importlib
from dataclasses import dataclass
from importlib.metadata import entry_points
from typing import Any, Protocol

from tuner.commands.common import UsageError

__all__ = ["ENGINE", "ENTRY_POINT_GROUP", "Command", "EngineCommand", "engine_command", "plugin_names",
           "load_plugin", "add_command", "runs_code"]

ENTRY_POINT_GROUP = "tuner.commands"


@dataclass(frozen=True)
class EngineCommand:
    """An engine command: its module under ``tuner/commands/``, its line in ``tuner --help``, and whether it
    runs the code a config names (``runs_code``; the others run under :func:`tuner.trust.data_only`)."""

    module: str
    help: str
    runs_code: bool = False


#: every engine command, in the order ``tuner --help`` lists them; ``runs_code`` marks the commands that may
#: load the code a config names (a ``kind: python`` module, a plant's Python dynamics, an FMU), the rule of
#: :mod:`tuner.trust` and of the README's "what happens when" table
ENGINE: dict[str, EngineCommand] = {
    "run": EngineCommand("run", "tune: run a job from a YAML config", runs_code=True),
    "resume": EngineCommand("resume", "continue an interrupted run from its checkpoint", runs_code=True),
    "show": EngineCommand("show", "summary of a run or a sweep directory"),
    "compare": EngineCommand("compare", "two or more runs side by side (parameters and metrics)"),
    "list": EngineCommand("listing", "what can be named in a config, or the runs of a directory"),
    "describe": EngineCommand("describe", "parameters, bounds, units and equations of a filter, controller, "
                                          "optimizer, metric, objective kind or data source"),
    "export": EngineCommand("export", "best parameters as yaml, json, python or a C header, or the tuned "
                                      "system as C99 source"),
    "verify-c": EngineCommand("verify_c", "compile a run's exported C, score it next to the model", runs_code=True),
    "evaluate": EngineCommand("evaluate", "score parameters without tuning (default: a run's best)", runs_code=True),
    "cv": EngineCommand("cv", "cross-validate a config: tune on the other folds, score the held-out fold",
                        runs_code=True),
    "sweep": EngineCommand("sweep", "run many jobs (configs x overrides x seeds) and write one report",
                           runs_code=True),
    "report": EngineCommand("report", "(re)write the report of a sweep directory or a run directory, or the "
                                      "dashboard (index.html) of a folder of runs"),
    "dashboard": EngineCommand("dashboard", "write DIR/index.html: every run and sweep under DIR, sortable, "
                                            "filterable, compared side by side"),
    "init": EngineCommand("init", "write a commented starter job for a filter or controller"),
    "demo": EngineCommand("demo", "run a job shipped with the package (default: the demo, EKF vs FAEKF)",
                          runs_code=True),
}


class Command(Protocol):
    """What a command added through :data:`ENTRY_POINT_GROUP` is."""

    name: str
    help: str

    def add_arguments(self, parser: argparse.ArgumentParser) -> None: ...

    def run(self, args: argparse.Namespace) -> int: ...


def engine_command(name: str) -> Any:
    """The module of engine command ``name`` (imported now)."""
    return importlib.import_module(f"tuner.commands.{ENGINE[name].module}")


def _entry_points() -> dict[str, Any]:
    """``{name: entry point}`` of :data:`ENTRY_POINT_GROUP` (one per name; a distribution seen on two
    ``sys.path`` entries counts once, two distributions naming one command are an error naming both)."""
    out: dict[str, Any] = {}
    for ep in entry_points(group=ENTRY_POINT_GROUP):
        if ep.name in ENGINE:
            continue  # an engine command is never replaced
        old = out.get(ep.name)
        if old is not None and old.value != ep.value:
            raise UsageError(f"command {ep.name!r} is registered twice: by {_where(old)} and by {_where(ep)}; "
                             "uninstall one of them")
        out[ep.name] = ep
    return out


def _where(ep: Any) -> str:
    return f"{getattr(getattr(ep, 'dist', None), 'name', '?')} ({ep.value})"


def plugin_names() -> list[str]:
    """The names of the commands other packages add (their modules are not imported)."""
    return sorted(_entry_points())


def plugin_source(name: str) -> str:
    """The distribution that adds the command ``name`` (read from its metadata; nothing is imported)."""
    return getattr(getattr(_entry_points()[name], "dist", None), "name", None) or "another package"


def load_plugin(name: str) -> Command:
    """The command ``name`` of :data:`ENTRY_POINT_GROUP`; :class:`UsageError` naming the package when it
    does not load or is not a command."""
    ep = _entry_points()[name]
    try:
        cmd = ep.load()
    except Exception as exc:  # noqa: BLE001 - any failure of a third-party import is one line naming it
        raise UsageError(f"command {name!r}: registered by {_where(ep)} but does not load: "
                         f"{type(exc).__name__}: {exc}") from None
    missing = [a for a in ("name", "help", "add_arguments", "run") if not hasattr(cmd, a)]
    if missing:
        raise UsageError(f"command {name!r}: registered by {_where(ep)} but is not a command: no "
                         f"{', '.join(missing)}")
    if cmd.name != name:
        raise UsageError(f"command {name!r}: registered by {_where(ep)} but calls itself {cmd.name!r}")
    return cmd


def runs_code(name: str, command: Any = None) -> bool:
    """Whether command ``name`` (an engine command, or ``command``, one another package adds) may load the
    code a config names (:mod:`tuner.trust`)."""
    if name in ENGINE:
        return ENGINE[name].runs_code
    return getattr(command, "runs_code", False) is True


def add_command(sub: Any, name: str, help: str, command: Any = None) -> argparse.ArgumentParser:
    """The sub-parser of ``name`` in ``sub``; with ``command`` (a module or :class:`Command`) its arguments."""
    about = getattr(command, "DESCRIPTION", None) or getattr(command, "help", None)
    p = sub.add_parser(name, help=help, description=about)
    if command is not None:
        command.add_arguments(p)
        p.set_defaults(_run=command.run, _runs_code=runs_code(name, command))
    return p
