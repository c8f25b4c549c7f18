"""The ``tuner`` command line: the dispatcher of the commands of :mod:`tuner.commands` (one module each).

Exit status: 0 success, 1 a run failed or was interrupted, 2 bad input (config, arguments, run
directory), printed as one line ``error: <file>: <key>: <what is wrong and what is allowed>``.
"""

from __future__ import annotations

import argparse
import os
import sys
from contextlib import nullcontext
from typing import Any

from tuner import signals, trust
from tuner._version import __version__
from tuner.commands import ENGINE, add_command, engine_command, load_plugin, plugin_names, plugin_source
from tuner.commands.common import UsageError
from tuner.config import ConfigError
from tuner.records import RunError
from tuner.registry import RegistryError
from tuner.safe_io import UnsafeFile
from tuner.space import SpaceError

__all__ = ["main", "build_parser", "UsageError"]

EPILOG = """examples:
  tuner run configs/demo.yaml                      the demo (a sweep file runs as a sweep)
  tuner run configs/ekf_bench6dof.yaml --seed 3 --n-jobs 1   override seed and workers
  tuner run job.yaml --set optimizer.population=40 --set objective.metric=broad_total_rmse
  tuner resume runs/20261122T101500Z-demo-a1b2c3   continue an interrupted run
  tuner show runs/20261122T101500Z-demo-a1b2c3     summary of a run (or a sweep directory)
  tuner export RUN_DIR --format c > tuned.h        best parameters as a C header
  tuner export RUN_DIR --format c-source --out fw  the tuned filter itself as C99 (fw/<prefix>.h, .c)
  tuner verify-c RUN_DIR                           that C compiled and scored next to the Python model
  tuner evaluate RUN_DIR --data other.yaml --json  score the best parameters on other data
  tuner sweep configs/thesis_tilt_sweep.yaml       many runs and one report
  tuner dashboard runs                             runs/index.html: every run and sweep, sortable, compared
  tuner list                                       optimizers, objectives, filters, controllers, metrics, data
  tuner describe ekf                               parameters, bounds, units and equations of one name
  tuner init madgwick                              write madgwick.yaml, a commented starter job
  tuner demo                                       the packaged demo (EKF vs FAEKF, about two minutes)
"""


def build_parser(command: str | None = None) -> argparse.ArgumentParser:
    """The parser of ``tuner``: every command's help line, and the arguments of ``command`` alone.

    Only ``command``'s module is imported (:mod:`tuner.commands`); ``tuner --help`` names the commands other
    packages add, and the package, without importing them (a package's import may load numba).
    """
    ap = argparse.ArgumentParser(
        prog="tuner", formatter_class=argparse.RawDescriptionHelpFormatter, epilog=EPILOG,
        description="Tune attitude filters and robot controllers by global optimisation "
                    "(PSO, CMA-ES, differential evolution).")
    ap.add_argument("--version", action="version", version=f"tuner {__version__}")
    sub = ap.add_subparsers(dest="command", metavar="COMMAND")
    for name, spec in ENGINE.items():
        add_command(sub, name, spec.help, engine_command(name) if name == command else None)
    if command in ENGINE:
        return ap
    for name in plugin_names():  # read only for a command the engine does not have, and for --help
        if name == command:
            plugin = load_plugin(name)
            add_command(sub, name, plugin.help, plugin)
        else:  # not imported: a package's import may be heavy (the domain's loads numba), and --help stays light
            add_command(sub, name, f"a command of {plugin_source(name)}: tuner {name} --help")
    return ap


def _command_name(argv: list[str]) -> str | None:
    """The command ``argv`` names: its first word that is not an option (``tuner`` has no option that takes
    a value before the command)."""
    return next((a for a in argv if not a.startswith("-")), None)


def main(argv: list[str] | None = None) -> int:
    """Run ``tuner ARGV``; the exit status (see the module docstring)."""
    argv = sys.argv[1:] if argv is None else list(argv)
    try:
        ap = build_parser(_command_name(argv))
    except UsageError as exc:  # a command another package adds that does not load
        print(f"error: {exc}", file=sys.stderr)
        return 2
    a = ap.parse_args(argv)
    if not a.command:
        ap.print_help()
        return 2
    old_handlers = signals.install()  # SIGTERM and SIGHUP stop every command as Ctrl-C does
    try:
        try:
            # a command that does not run code never loads the code a config names (tuner.trust)
            with nullcontext() if a._runs_code else trust.data_only(f"tuner {a.command}"):
                code = a._run(a)
            sys.stdout.flush()
            return code
        except (ConfigError, RunError, SpaceError, UsageError, RegistryError) as exc:
            print(f"error: {exc}", file=sys.stderr)
            return 2
        except UnsafeFile as exc:  # a link, a FIFO, a hard link, an oversized file in a run directory
            print(f"error: {exc.filename}: {exc.strerror}", file=sys.stderr)
            return 2
        except OSError as exc:  # read-only directory, full disk...: one line naming the path
            if isinstance(exc, BrokenPipeError):
                raise
            where = exc.filename or "?"
            print(f"error: {where}: {exc.strerror or exc} (results written before this point are kept; "
                  "`tuner resume` continues a run)", file=sys.stderr)
            return 2
        except KeyboardInterrupt:  # runs handle their own; `tuner cv CONFIG` or a report stops here
            print("interrupted", file=sys.stderr)
            return 1
    except BrokenPipeError:  # stdout closed early (`tuner list | head -1`): stop quietly
        _silence_stdout()
        return 0
    finally:
        signals.restore(old_handlers)


def _silence_stdout() -> None:
    """Point stdout at /dev/null so that the interpreter's final flush does not fail again."""
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        os.close(devnull)
    except (OSError, ValueError):  # pragma: no cover
        pass


def _entry() -> Any:  # pragma: no cover
    sys.exit(main())


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
