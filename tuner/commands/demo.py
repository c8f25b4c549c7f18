"""``tuner demo [JOB]``: run a job shipped with the package (default: the demo, EKF vs FAEKF)."""

from __future__ import annotations

import argparse

from tuner.commands import run as run_command
from tuner.commands.common import UsageError
from tuner.starter import OWN_DATA_EXAMPLES, StarterError, packaged_config, packaged_configs


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("job", nargs="?", default="demo", help="a packaged job, e.g. thesis_kf1d (see --list)")
    p.add_argument("--list", action="store_true", help="list the packaged jobs and where they are")
    p.add_argument("-q", "--quiet", action="store_true")


def run(a: argparse.Namespace) -> int:
    if a.list:
        names = packaged_configs()
        print(f"packaged jobs ({packaged_config(names[0]).parent}):")
        print("  " + ", ".join(n.removesuffix(".yaml") for n in names))
        for job, columns in OWN_DATA_EXAMPLES.items():  # the README's "Your own data" example
            path = packaged_config(job)
            print(f"your own CSV: {job.removesuffix('.yaml')} ({path}); its column map: {path.parent / columns}, "
                  "copy both and point them at your file (`tuner describe csv`)")
        return 0
    try:
        path = packaged_config(a.job if a.job.endswith(".yaml") else f"{a.job}.yaml")
    except StarterError as exc:
        raise UsageError(str(exc)) from None
    return run_command.run(argparse.Namespace(config=str(path), overrides=[], seed=None, n_jobs=None, repeats=None,
                                              run_dir=None, no_report=False, quiet=a.quiet))
