"""Leave-one-group-out CV of many tuning setups at once, for filters with one to three searched parameters.

On a 2-core machine one PSO-based CV run of VQF costs about 7 x 96 filter runs on 16 trials. For a
low-dimensional space the per-trial scores of a log grid can be computed once and every tuning
setup (aggregation, group balance, prior strength) cross-validated on that score matrix: the tuner
of each fold is then an exhaustive grid search (the grid's best point under that fold's fitness),
which is what PSO approximates. Scores are cached in ``--cache`` (npz) so setups can be added later.

Examples::

    python benchmarks/broad_cv_grid.py vqf tauAcc=0.3:30:10 tauMag=1:100:10
    python benchmarks/broad_cv_grid.py vqf tauAcc=0.3:30:8 tauMag=1:100:8 --fixed offline=true
"""

from __future__ import annotations

import argparse
import itertools
import sys
import time
from pathlib import Path

import numpy as np

try:
    from benchmarks.broad_cv_common import BROAD_DIR, RESULTS_MD, broad_folds, pairs, publish
except ImportError:  # run as a script: benchmarks/ is on the path (broad_cv_common puts the checkout there)
    from broad_cv_common import BROAD_DIR, RESULTS_MD, broad_folds, pairs, publish

from objectives.attitude.aggregate import aggregate, group_weights, prior_penalty  # noqa: E402
from objectives.attitude.trials import filter_class, score_trials, search_space  # noqa: E402

#: (label, aggregation, options, group_balanced, prior strength in deg)
SETUPS = [
    ("mean", "mean", {}, False, 0.0),
    ("mean + prior 1", "mean", {}, False, 1.0),
    ("mean + prior 3", "mean", {}, False, 3.0),
    ("median", "median", {}, False, 0.0),
    ("worst-3", "worst_k", {"k": 3}, False, 0.0),
    ("CVaR(0.5)", "cvar", {"alpha": 0.5}, False, 0.0),
    ("group-balanced mean", "mean", {}, True, 0.0),
    ("group-balanced mean + prior 1", "mean", {}, True, 1.0),
    ("group-balanced CVaR(0.5)", "cvar", {"alpha": 0.5}, True, 0.0),
]


def _fitness(S, idx, names, groups, agg, kw, balanced, prior):
    w = group_weights([names[i] for i in idx], groups) if balanced else None
    k = kw.get("k")
    kw = dict(kw, k=min(k, len(idx))) if k else kw
    return np.array([aggregate(S[p, idx], agg, weights=w, **kw) for p in range(S.shape[0])]) + prior


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("filter")
    ap.add_argument("grid", nargs="+", help="NAME=LOW:HIGH:N (log-spaced)")
    ap.add_argument("--fixed", nargs="*", default=[])
    ap.add_argument("--data", default=str(BROAD_DIR))
    ap.add_argument("--init", default="accmag")
    ap.add_argument("--n-jobs", type=int, default=2)
    ap.add_argument("--cache", default="")
    ap.add_argument("--out", default=str(RESULTS_MD))
    ap.add_argument("--title", default="")
    a = ap.parse_args(argv)

    paths, groups, folds = broad_folds(a.data)
    paths = {k: str(v) for k, v in paths.items()}
    names = list(paths)
    fixed = pairs(a.fixed, "--fixed")
    axes = {}
    for g in a.grid:
        k, spec = g.split("=", 1)
        lo, hi, n = spec.split(":")
        axes[k] = np.geomspace(float(lo), float(hi), int(n))
    space = search_space(a.filter, {k: {"low": float(v[0]), "high": float(v[-1]), "scale": "log"}
                                    for k, v in axes.items()}, fixed)
    points = [dict(zip(axes, combo)) for combo in itertools.product(*axes.values())]
    cache = Path(a.cache) if a.cache else None
    t0 = time.perf_counter()
    if cache and cache.exists():
        S = np.load(cache)["S"]
    else:
        from joblib import Parallel, delayed

        plist = [paths[n] for n in names]
        rows = Parallel(n_jobs=a.n_jobs, backend="loky")(
            delayed(score_trials)(a.filter, {**fixed, **p}, plist, a.init) for p in points)
        S = np.array(rows)
        if cache:
            np.savez(cache, S=S)
    secs = time.perf_counter() - t0
    center = {**filter_class(a.filter).defaults, **fixed}
    d_scores = score_trials(a.filter, center, [paths[n] for n in names], a.init)
    prior_u = np.array([prior_penalty(p, space, center, 1.0) for p in points])

    lines = [f"\n### {a.title or a.filter} (grid)\n",
             f"`python benchmarks/broad_cv_grid.py {' '.join(argv or sys.argv[1:])}` "
             f"({len(points)} points x {len(names)} trials, {secs:.0f} s); each fold tuned by exhaustive search "
             f"of the grid; init {a.init}; fixed {fixed}.", "",
             f"Defaults ({', '.join(f'{k}={center[k]:g}' for k in axes)}): mean {d_scores.mean():.3f}, "
             f"worst {d_scores.max():.2f}. Grid optimum of the mean on all 16: {S.mean(axis=1).min():.3f}.", "",
             "| setup | tuned on all 16 | train mean | LOGO-CV mean | CV std | CV worst | CV group-bal. | "
             "gap | params on all 16 |", "|---|---|---|---|---|---|---|---|---|"]
    per_trial = {}
    all_idx = np.arange(len(names))
    for label, agg, kw, bal, prior in SETUPS:
        f_all = _fitness(S, all_idx, names, groups, agg, kw, bal, prior * prior_u)
        p_all = int(np.argmin(f_all))
        cv = np.empty(len(names))
        for f in folds:
            tr = np.array([names.index(n) for n in f.train])
            te = np.array([names.index(n) for n in f.test])
            p = int(np.argmin(_fitness(S, tr, names, groups, agg, kw, bal, prior * prior_u)))
            cv[te] = S[p, te]
        per_trial[label] = cv
        gw = group_weights(names, groups)
        train = S[p_all].mean()
        pstr = ", ".join(f"{k}={points[p_all][k]:.3g}" for k in axes)
        lines.append(f"| {label} | {f_all[p_all]:.3f} | {train:.3f} | {cv.mean():.3f} | {cv.std():.2f} | "
                     f"{cv.max():.2f} | {np.sum(gw * cv):.3f} | {cv.mean() - train:+.3f} | {pstr} |")
    lines.append(f"| defaults | | {d_scores.mean():.3f} | {d_scores.mean():.3f} | {d_scores.std():.2f} | "
                 f"{d_scores.max():.2f} | {np.sum(group_weights(names, groups) * d_scores):.3f} | 0 | |")
    lines += ["", "Per group, LOGO-CV mean (deg):", "",
              "| group | defaults | " + " | ".join(per_trial) + " |", "|---" * (len(per_trial) + 2) + "|"]
    for g in dict.fromkeys(groups[n] for n in names):
        idx = [i for i, n in enumerate(names) if groups[n] == g]
        lines.append(f"| {g} ({len(idx)}) | {d_scores[idx].mean():.2f} | "
                     + " | ".join(f"{v[idx].mean():.2f}" for v in per_trial.values()) + " |")
    publish(a.out, lines)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
