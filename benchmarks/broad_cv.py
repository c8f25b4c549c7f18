"""Leave-one-group-out cross-validation of a filter's tuning on the 16 shared BROAD trials.

Folds: the level-2 motion/disturbance groups of BROAD's ``trials.json`` (rotation, translation,
tapping, vibration, stationary_magnet, attached_magnet), each trial held out exactly once. For each
fold the filter is tuned on the other groups' trials and scored on the held-out group; the table
puts defaults, the tuning score on all 16 and the held-out score side by side. The Markdown table is
appended to ``--out`` (default ``benchmarks/results/broad_cv.md``) with the command line.

Examples::

    python benchmarks/broad_cv.py vqf --search tauAcc tauMag --pso 12x8
    python benchmarks/broad_cv.py vqf --search tauAcc tauMag --prior 2 --aggregation cvar --alpha 0.5
    python benchmarks/broad_cv.py ekf --fixed p0_b=1e-4 gyro_sample=current --search q_q q_w rho huber_deg acc_gate
"""

from __future__ import annotations

import argparse
import shlex
import sys
import time
from pathlib import Path

import yaml

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
#: ../shared/data/broad of the checkout (or of its parent, for a worktree one level deeper)
_CANDIDATES = [base / "shared" / "data" / "broad" for base in (ROOT.parent, ROOT.parent.parent)]
BROAD_DIR = next((d for d in _CANDIDATES if d.is_dir()), _CANDIDATES[0])

from objectives.attitude.aggregate import AGGREGATIONS  # noqa: E402
from objectives.attitude.cv import (  # noqa: E402
    TuneOptions,
    broad_trial_groups,
    cross_validate,
    logo_folds,
    search_space,
)


def _value(text: str):
    return yaml.safe_load(text)


def _pairs(items: list[str], what: str) -> dict:
    out = {}
    for it in items or []:
        if "=" not in it:
            raise SystemExit(f"{what}: expected NAME=VALUE, got {it!r}")
        k, v = it.split("=", 1)
        out[k] = _value(v)
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("filter")
    ap.add_argument("--data", default=str(BROAD_DIR),
                    help="BROAD directory with the .mat files and trials.json")
    ap.add_argument("--search", nargs="*", default=None,
                    help="parameters to search (filter's bounds, or NAME=LOW:HIGH[:log]); default: the filter's space")
    ap.add_argument("--fixed", nargs="*", default=[], help="NAME=VALUE options passed to the filter")
    ap.add_argument("--pso", default="12x8", help="population x generations")
    ap.add_argument("--method", default="pso")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--aggregation", default="mean", choices=AGGREGATIONS)
    ap.add_argument("--k", type=int, default=None)
    ap.add_argument("--alpha", type=float, default=None)
    ap.add_argument("--group-balanced", action="store_true")
    ap.add_argument("--prior", type=float, default=0.0, help="prior strength (deg) toward the defaults")
    ap.add_argument("--init", default="accmag", choices=("accmag", "truth", "broad"))
    ap.add_argument("--n-jobs", type=int, default=2)
    ap.add_argument("--no-full", action="store_true", help="skip tuning on all 16 (no tuning score)")
    ap.add_argument("--out", default=str(ROOT / "benchmarks" / "results" / "broad_cv.md"))
    ap.add_argument("--title", default="")
    a = ap.parse_args(argv)

    data = Path(a.data)
    paths = {p.stem: p for p in sorted(data.glob("*.mat"))}
    if not paths:
        raise SystemExit(f"{data}: no BROAD .mat files")
    groups = broad_trial_groups(data, list(paths))
    folds = logo_folds(list(paths), groups)
    search = None
    if a.search is not None:
        search = {}
        for s in a.search:
            if "=" in s:
                name, rng = s.split("=", 1)
                lo, hi, *sc = rng.split(":")
                search[name] = {"low": float(lo), "high": float(hi), "scale": sc[0] if sc else "linear"}
            else:
                search[s] = None
    space = search_space(a.filter, search, _pairs(a.fixed, "--fixed"))
    pop, gen = (int(x) for x in a.pso.lower().split("x"))
    opts = TuneOptions(method=a.method, population=pop, generations=gen, seed=a.seed, aggregation=a.aggregation,
                       k=a.k, alpha=a.alpha, group_balanced=a.group_balanced, prior_strength=a.prior,
                       init=a.init, n_jobs=a.n_jobs)
    t0 = time.perf_counter()
    res = cross_validate(a.filter, paths, folds, groups, space, opts, full=not a.no_full,
                         progress=lambda m: print(m, flush=True))
    secs = time.perf_counter() - t0
    cmd = "python benchmarks/broad_cv.py " + " ".join(shlex.quote(x) for x in (argv or sys.argv[1:]))
    when = time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime())
    text = f"\n### {a.title or a.filter}\n\n`{cmd}` ({secs:.0f} s, {when})\n\n{res.to_markdown()}"
    print(text)
    out = Path(a.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    with out.open("a") as fh:
        fh.write(text)
    s = res.summary()
    print("SUMMARY " + " ".join(f"{k}={v:.3f}" for k, v in s.items()))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
