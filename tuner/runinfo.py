"""What a run tuned and how it validated, for ``tuner show``, ``tuner compare``, ``tuner list runs`` and the
run report.

:func:`run_summary` gathers status, best fitness, parameters and counts from ``meta.json`` and
``best.yaml`` (here rather than in :mod:`tuner.report`, so ``tuner show`` imports neither pandas nor
the report's figures).

:func:`tuned_system` names the filter or controller and the settings the run held fixed: from the
complete deployment record in ``best.yaml`` (``deployment:``, values whose source is ``fixed``) when the
run has one, else from the run's resolved ``config.yaml`` (``objective.fixed`` and ``parameters: {x:
{fixed: v}}`` or bare values). :func:`scores` gathers the held-out numbers ``best.yaml`` records: the CV
score, the tuning score and their gap (``validation:``), the test score, and the defaults scored the
same ways (:func:`tuner.validation.defaults_scores`).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

from tuner.rundir import RunDir

__all__ = ["run_summary", "tuned_system", "scores", "SCORE_KEYS", "list_runs", "unreadable"]

#: the numbers of ``best.yaml``'s ``evaluation`` that show and compare print, in order
SCORE_KEYS = ("train_fitness", "test_fitness", "tuning_score", "cv_fitness", "cv_gap", "defaults_fitness",
              "defaults_train_fitness", "defaults_test_fitness", "defaults_cv_fitness")
#: objective keys that name what is tuned, by objective kind (first present wins)
_NAME_KEYS = ("filter", "controller", "function", "callable")


def run_summary(run_dir: Path, meta: dict[str, Any] | None = None) -> dict[str, Any]:
    """Status, best fitness, parameters and counts of a run directory (``meta`` replaces ``meta.json``)."""
    run_dir = Path(run_dir)
    rd = RunDir(run_dir)
    if meta is None:
        meta = rd.meta().to_dict()  # RunError naming the file if meta.json is corrupt
    elif not isinstance(meta, dict):
        meta = meta.to_dict()
    best = rd.best().to_doc() if rd.has_best() else {}
    return {"run": rd.path.name, "status": meta.get("status"), "optimizer": meta.get("optimizer"),
            "seed": meta.get("seed"), "n_evals": meta.get("n_evals"), "n_failed": meta.get("n_failed"),
            "best_fitness": best.get("fitness"), "params": best.get("params", {}),
            "metrics": best.get("metrics", {}), "evaluation": best.get("evaluation", {}) or {},
            "wall_s": (meta.get("timing") or {}).get("wall_s"), "stop_reason": meta.get("stop_reason", ""),
            "created": meta.get("created"), "found": best.get("found", {}), "name": meta.get("name", ""),
            "notes": list(meta.get("notes") or [])}


def tuned_system(run_dir: str | Path) -> dict[str, Any]:
    """``{kind, name, searched: [names], fixed: {name: value}, notes: [text]}`` of a run (see the module
    docstring); ``notes`` are the deployment's (e.g. a scoring-only truth start replaced by ``accmag``).

    ``searched`` are the names the run's search space searched; ``fixed`` every other value the run handed
    to the objective (its space's fixed part: ``objective.fixed``, ``parameters: {x: {fixed: v}}`` and the
    options the space holds at their declared values).
    """
    rd = RunDir(run_dir)
    best = rd.best() if rd.has_best() else None
    dep = getattr(best, "deployment", None) or {}
    if isinstance(dep.get("values"), dict) and isinstance(dep.get("sources"), dict):
        src = dep["sources"]
        return {"kind": str(dep.get("kind", "")), "name": str(dep.get("name", "")),
                "searched": [k for k in dep["values"] if src.get(k) == "searched"],
                "fixed": {k: v for k, v in dep["values"].items() if src.get(k) == "fixed"},
                "notes": [str(n) for n in dep.get("notes") or []]}
    raw = rd.config()
    obj = raw.get("objective") or {}
    name = next((str(obj[k]) for k in _NAME_KEYS if obj.get(k) is not None), "")
    params = raw.get("parameters") or {}
    searched = [k for k, spec in params.items() if isinstance(spec, dict) and "low" in spec and "fixed" not in spec]
    fixed = {k: v for k, v in (best.params if best else {}).items() if k not in searched}
    for k, spec in params.items():
        if k not in searched and k not in fixed:
            fixed[k] = spec["fixed"] if isinstance(spec, dict) and "fixed" in spec else spec
    fixed.update({k: v for k, v in (obj.get("fixed") or {}).items() if k not in searched})
    return {"kind": str(obj.get("kind", "")), "name": name, "searched": searched, "fixed": fixed, "notes": []}


def scores(evaluation: dict[str, Any]) -> dict[str, Any]:
    """The :data:`SCORE_KEYS` present in ``evaluation`` (finite or not), plus ``cv_gap_large``."""
    out = {k: evaluation[k] for k in SCORE_KEYS if isinstance(evaluation.get(k), (int, float))}
    if "cv_gap" in out:
        out["cv_gap_large"] = bool(evaluation.get("cv_gap_large"))
    return out


def fmt(v: Any) -> str:
    """A value as show prints it (``.6g`` for floats)."""
    if isinstance(v, float):
        return "-" if math.isnan(v) else f"{v:.6g}"
    return str(v)


def list_runs(runs_dir: Path) -> str:
    """A table of the run directories under ``runs_dir`` (recursively): status, best fitness, age; a run that
    cannot be read is listed as ``unreadable``, with the reason on a line after the table."""
    import datetime as _dt

    import pandas as pd

    from tuner.records import RunError

    rows, why = [], []
    now = _dt.datetime.now(_dt.UTC)
    for meta_p in sorted(Path(runs_dir).rglob("meta.json")):
        name = str(meta_p.parent.relative_to(runs_dir))
        try:
            rd = RunDir(meta_p.parent)
            meta = rd.meta()
            best = rd.best() if rd.has_best() else None
            age = ""
            if meta.created:
                dt = now - _dt.datetime.strptime(meta.created, "%Y-%m-%dT%H:%M:%SZ").replace(tzinfo=_dt.UTC)
                age = str(dt).split(".")[0]
        except (RunError, OSError, ValueError) as exc:  # one damaged run is listed as such, the others as usual
            rows.append({"run": name, "status": "unreadable", "optimizer": "", "evals": None, "best_fitness": None,
                         "age": ""})
            why.append(f"unreadable: {name}: {unreadable(exc)}")
            continue
        rows.append({"run": name, "status": meta.status, "optimizer": meta.optimizer,
                     "evals": meta.n_evals, "best_fitness": best.fitness if best else None, "age": age})
    if not rows:
        return f"no runs under {runs_dir}"
    return "\n".join([pd.DataFrame(rows).to_string(index=False), *why])


def unreadable(exc: BaseException) -> str:
    """Why a run directory of a listing could not be read: the first line of the error, short."""
    text = f"{exc.filename}: {exc.strerror}" if isinstance(exc, OSError) and exc.filename else str(exc)
    return (text.splitlines() or [type(exc).__name__])[0][:160]
