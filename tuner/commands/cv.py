"""``tuner cv CONFIG_OR_RUN``: cross-validate a config (tune on the other folds, score the held-out fold), or
a finished run (its tables go into the run directory)."""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from tuner import cv as crossval  # its functions looked up when the command runs (tests replace them)
from tuner.commands.common import fraction
from tuner.config import load_config
from tuner.registry import say_imports
from tuner.rundir import RunDir
from tuner.validation import cv_run_dir


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("config", help="a config file, or a finished run directory (its tables are written into it)")
    p.add_argument("--k", type=int, default=None, help="number of folds for k-fold (default: the objective's "
                   "groups, e.g. BROAD's trial groups, else 5)")
    p.add_argument("--dir", default=None, help="output directory (default: <output>/cv/<name>-<stamp>)")
    p.add_argument("--no-full", action="store_true", help="skip the tuning on all data (no gap)")
    p.add_argument("--budget-fraction", type=fraction, default=None,
                   help="each tuning's budget relative to the config's, in (0, 1] (default: the config's "
                        "validation.budget_fraction, else 1)")
    p.add_argument("-q", "--quiet", action="store_true")


def run(a: argparse.Namespace) -> int:
    progress = None if a.quiet else (lambda m: print(m, file=sys.stderr, flush=True))
    if Path(a.config).is_dir():  # a finished run: its best is the tuning result, the tables go into it
        say_imports(RunDir(a.config).config().get("objective") or {}, Path(a.config) / "config.yaml")
        v = cv_run_dir(a.config, k=a.k, progress=progress, budget_fraction=a.budget_fraction)
        print(f"CV mean {v['cv_score']:.4g} (defaults {v['defaults_cv_score']:.4g}), tuning score "
              f"{v['tuning_score']:.4g}, gap {v['gap']:+.3g}{' (large)' if v['gap_large'] else ''}\n{a.config}")
        return 0
    cfg = load_config(a.config)
    frac = cfg.validation.budget_fraction if a.budget_fraction is None else a.budget_fraction
    out = crossval.cross_validate(cfg, k=a.k, full=not a.no_full, progress=progress, budget_fraction=frac)
    stamp = time.strftime("%Y%m%d-%H%M%S", time.gmtime())
    d = crossval.write_cv(out, a.dir or Path(cfg.output) / "cv" / f"{cfg.name}-{stamp}", cfg.validation)
    s = out.summary()
    print(f"CV mean {s['cv_mean']:.4g} (defaults {s['defaults_mean']:.4g})"
          + (f", tuning score {s['tuning_score']:.4g}, gap {s['gap']:+.3g}" if "gap" in s else "") + f"\n{d}")
    return 0
