"""What the BROAD cross-validation benchmarks share: where the checkout and the data are, the folds, a job.

``benchmarks/broad_cv.py`` (the engine's cross-validation, ``tuner cv``, of a job written by
:func:`broad_config`, and of every ``configs/broad_*.yaml`` for ``make bench``) and
``benchmarks/broad_cv_grid.py`` (many tuning setups on one grid of scores) both use it.
"""

from __future__ import annotations

import sys
from pathlib import Path

import yaml

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:  # run as a script: benchmarks/ is on the path, the checkout is not
    sys.path.insert(0, str(ROOT))
#: ../shared/data/broad of the checkout (or of its parent, for a worktree one level deeper)
_CANDIDATES = [base / "shared" / "data" / "broad" for base in (ROOT.parent, ROOT.parent.parent)]
BROAD_DIR = next((d for d in _CANDIDATES if d.is_dir()), _CANDIDATES[0])
RESULTS_MD = ROOT / "benchmarks" / "results" / "broad_cv.md"

__all__ = ["ROOT", "BROAD_DIR", "RESULTS_MD", "pairs", "broad_folds", "broad_config", "append", "publish"]


def pairs(items: list[str] | None, what: str) -> dict:
    """``NAME=VALUE`` strings (values parsed as YAML) as a dict; a malformed item stops the script."""
    out = {}
    for it in items or []:
        if "=" not in it:
            raise SystemExit(f"{what}: expected NAME=VALUE, got {it!r}")
        k, v = it.split("=", 1)
        out[k] = yaml.safe_load(v)
    return out


def broad_folds(data: str | Path):
    """``(paths, groups, folds)`` of the BROAD ``.mat`` files in ``data``: leave-one-group-out folds."""
    from objectives.attitude.trials import broad_trial_groups, logo_folds

    data = Path(data)
    paths = {p.stem: p for p in sorted(data.glob("*.mat"))}
    if not paths:
        raise SystemExit(f"{data}: no BROAD .mat files")
    groups = broad_trial_groups(data, list(paths))
    return paths, groups, logo_folds(list(paths), groups)


def broad_config(filter_name: str, data: str | Path, search: dict | None = None, fixed: dict | None = None, *,
                 trials: list[str] | None = None, method: str = "pso", population: int = 12, generations: int = 8,
                 seed: int = 1, aggregation: str = "mean", k: int | None = None, alpha: float | None = None,
                 group_balanced: bool = False, prior: float = 0.0, init: str = "accmag", n_jobs: int = 1):
    """The tuning job (a :class:`tuner.config.RunConfig`) of ``filter_name`` on BROAD trials, as a config says it.

    ``search`` maps parameter names to ``{low, high, scale}`` or ``None`` (the filter's own bounds);
    ``None`` searches the filter's whole space. Every other parameter stays at ``fixed`` or the filter's
    default. ``trials`` (default: every ``.mat`` in ``data``) are the tuning recordings; the engine's
    cross-validation (:func:`tuner.cv.cross_validate`) holds out BROAD's trial groups in turn. The
    aggregation, group balance and prior (deg, toward the defaults) become the objective's
    ``metric_options`` and ``prior``; ``init`` its ``q0``. ``ValueError`` / ``ConfigError`` for bad values.
    """
    from objectives.attitude.trials import filter_class
    from tuner.config import config_from_dict

    data = Path(data).resolve()
    names = list(trials) if trials is not None else [p.stem for p in sorted(data.glob("*.mat"))]
    if not names:
        raise ValueError(f"{data}: no BROAD .mat files")
    own = {p.name: p for p in filter_class(filter_name).space().params}
    params = None
    if search is not None:
        unknown = sorted(set(search) - set(own))
        if unknown:
            raise ValueError(f"{filter_name}: cannot search {unknown}; searchable: {sorted(own)}")
        params = {n: (dict(spec) if spec is not None else own[n].to_dict()) for n, spec in search.items()}
    opts: dict = {}
    if aggregation != "mean" or group_balanced:
        opts = {"aggregate": aggregation, **({"k": k} if k is not None else {}),
                **({"alpha": alpha} if alpha is not None else {}),
                **({"group_balanced": True} if group_balanced else {})}
    objective = {"kind": "filter", "filter": filter_name, "fixed": dict(fixed or {}),
                 "data": [{"broad": {"dir": str(data), "trials": names}}], "metric": "broad_mean_rmse",
                 "q0": init, **({"metric_options": opts} if opts else {}),
                 **({"prior": {"strength": float(prior), "center": "defaults"}} if prior else {})}
    raw = {"name": f"broad-cv-{filter_name}", "seed": int(seed), "objective": objective,
           "optimizer": {"method": method, "population": int(population), "generations": int(generations)},
           "parallel": {"backend": "serial"} if n_jobs <= 1 else {"backend": "loky", "n_jobs": int(n_jobs)}}
    if params is not None:
        raw["parameters"] = params
    return config_from_dict(raw, source="benchmarks/broad_cv.py", base_dir=ROOT)


def append(out: str | Path, text: str) -> None:
    """Append ``text`` to the Markdown file ``out`` (created with its directory)."""
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    with out.open("a") as fh:
        fh.write(text)


def publish(out: str | Path, lines: list[str]) -> None:
    """Print the Markdown ``lines`` (one text, newline-terminated) and :func:`append` it to ``out``."""
    text = "\n".join(lines) + "\n"
    print(text)
    append(out, text)
