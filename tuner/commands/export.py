"""``tuner export RUN_DIR``: the best parameters as YAML, JSON, Python or a C header, or the tuned system
itself as C99 source (``--format c-source``, through the objective's ``export_c`` hook)."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from tuner.commands.common import UsageError
from tuner.export import C_SOURCE, C_SOURCE_ALIASES, FORMATS, export, export_c, export_own, objective_formats


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("run_dir")
    p.add_argument("--format", default="yaml", metavar="FORMAT",
                   help=f"{', '.join(FORMATS)} (default yaml); {C_SOURCE}: C99 header + source of the tuned system "
                        f"itself, the filter or the controller (see --precision, --out; "
                        f"{', '.join(C_SOURCE_ALIASES)}: the same for that kind of run); "
                        "or a format of the run's objective's own, e.g. ros2-params / ros1-params (the ROS node's "
                        "parameter file of a filter a ROS node runs)")
    p.add_argument("--precision", default="double", choices=["double", "float"], help=f"{C_SOURCE}: arithmetic")
    p.add_argument("--out", default=".", help=f"{C_SOURCE}: directory for <prefix>.h and <prefix>.c (default: .)")
    p.add_argument("-o", "--output", help="write to this file instead of standard output")
    p.add_argument("--prefix", help="C identifier prefix, e.g. EKF1 (default: from the run's name); lets two "
                                    "headers be included in one file")


def _verdict(run_dir: Path) -> str | None:
    from tuner.rundir import RunDir
    from tuner.verdict import defaults_verdict

    return defaults_verdict(RunDir(run_dir).best().evaluation)


def run(a: argparse.Namespace) -> int:
    run_dir = Path(a.run_dir)
    source = a.format in (C_SOURCE, *C_SOURCE_ALIASES)
    if not (run_dir / "best.yaml").exists():
        raise UsageError(f"{run_dir}: no best.yaml (not a run directory, or nothing evaluated yet)")
    if a.prefix is not None and a.format != "c" and not source:
        raise UsageError(f"--prefix {a.prefix!r}: names C identifiers, only for --format c or {C_SOURCE} "
                         f"(got --format {a.format})")
    if a.prefix is not None and (not a.prefix.isidentifier() or not a.prefix.isascii()):
        raise UsageError(f"--prefix {a.prefix!r}: a C identifier ([A-Za-z_][A-Za-z0-9_]*)")
    verdict = _verdict(run_dir)
    if verdict:
        print(f"warning: {verdict}", file=sys.stderr)
    if a.format not in FORMATS and not source:
        own = objective_formats(run_dir)
        if a.format not in own:
            raise UsageError(f"--format {a.format!r}: allowed: {', '.join([*FORMATS, C_SOURCE, *own])}")
        if a.prefix is not None:
            raise UsageError(f"--prefix {a.prefix!r}: names C identifiers, not for --format {a.format}")
        return _emit(export_own(run_dir, a.format), a.output)
    if source:
        files = export_c(run_dir, a.precision, a.prefix, a.format)
        Path(a.out).mkdir(parents=True, exist_ok=True)
        for name, text in files.items():
            (Path(a.out) / name).write_text(text)
            print(f"wrote {Path(a.out) / name}", file=sys.stderr)
        return 0
    return _emit(export(run_dir, a.format, prefix=a.prefix), a.output)


def _emit(text: str, output: str | None) -> int:
    """``text`` to the file ``output`` (saying so on stderr) or to stdout; 0."""
    if output:
        Path(output).write_text(text)
        print(f"wrote {output}", file=sys.stderr)
    else:
        sys.stdout.write(text)
    return 0
