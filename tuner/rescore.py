"""Scoring without tuning: ``tuner evaluate CONFIG_OR_RUN_DIR [--params P.yaml] [--data D.yaml]``.

The parameters default to the run's best (for a run directory) or to the objective's defaults
(for a config). ``--data`` replaces the config's data with another list of data specs (or a
``{train, test}`` mapping), which is how tuned parameters are checked on new recordings.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

from tuner.config import ConfigError, load_config, read_yaml
from tuner.objective import hook
from tuner.registry import say_imports
from tuner.rundir import RunDir
from tuner.setup import build_objective, run_config

__all__ = ["evaluate_target"]


def evaluate_target(target: str | Path, params_file: str | Path | None = None,
                    data_file: str | Path | None = None) -> dict[str, Any]:
    """``{"fitness": float, "recordings": {name: {metric: value}}, "params": {...}, "deployment": {...}}``
    (plus test scores, and ``warnings`` of the ``--data`` recordings' preflight); ``deployment`` is the
    complete configuration the scored parameters deploy (:mod:`tuner.deployment`)."""
    target = Path(target)
    best_params = None
    if target.is_dir():
        rd = RunDir(target)
        if not rd.file("config.yaml").exists():
            raise ConfigError(target, "", "not a run directory (no config.yaml)")
        cfg = run_config(rd)
        if rd.has_best():
            best_params = dict(rd.best().params)
    else:
        cfg = load_config(target)
    say_imports(cfg.objective, cfg.source)
    objective = build_objective(cfg)
    space = cfg.space(objective)
    if params_file:
        doc = read_yaml(params_file, "--params")
        params = dict(doc.get("params", doc)) if isinstance(doc, dict) else None
        if params is None:
            raise ConfigError(params_file, "", "expected a mapping of parameters (or a best.yaml)")
    elif best_params is not None:
        params = best_params
    else:
        from tuner.deployment import defaults_baseline

        baseline = defaults_baseline(objective, space)  # the config's fixed values, searched ones at defaults
        if baseline is None:
            raise ConfigError(target, "", "no parameters: give --params (a config has no best)")
        params = {k: v for k, v in baseline.items() if k in space}
    names_fn = hook(objective, "parameter_names")
    unknown = sorted(set(params) - set(names_fn())) if params_file and names_fn is not None else []
    if unknown:  # a misspelt name would otherwise be reported as the right name missing
        raise ConfigError(params_file, f"params.{unknown[0]}", f"not a parameter of this objective; allowed: "
                                                                 f"{', '.join(sorted(names_fn()))}")
    full = {**space.fixed, **params}
    missing = [n for n in space.free_names if n not in full]
    if missing:
        raise ConfigError(params_file or target, "params", f"missing value(s) for {missing}")
    check = hook(objective, "check_params")
    try:  # a value the objective refuses is an error line, not a traceback from the scoring
        if check is not None:
            check(full)
    except ValueError as exc:
        raise ConfigError(params_file or target, "params", str(exc)) from None
    if data_file:  # the new data's preflight warnings (units, a start in motion), and its fingerprint's
        objective, warnings = objective_on_data(objective, data_file, target if target.is_dir() else None)
    else:  # the config's own data, loaded and checked as `tuner run` does: a NaN row is one error line
        warnings = _preflight(objective, cfg.source)
    from tuner.deployment import deployment_for

    deployment = deployment_for(objective, full, space.free_names, list(space.fixed)).to_doc()
    score = hook(objective, "score")
    if score is not None:
        s = score(full, "train")
        out = {"fitness": s.fitness, "recordings": _plain(s.recordings), "params": full, "deployment": deployment,
               **({"warnings": warnings} if warnings else {})}
        if s.failed:
            out["failed"] = s.failed
        has_test = hook(objective, "has_test_data")
        if not data_file and has_test is not None and has_test():
            t = score(full, "test")
            out["test_fitness"] = t.fitness
            out["test_recordings"] = _plain(t.recordings)
        return out
    from tuner.evaluate import evaluate_one

    rec = evaluate_one(objective, full)
    ev = rec.evaluation
    return {"fitness": ev.fitness if ev.status == "ok" else math.nan, "recordings": {"all": dict(ev.metrics)},
            "params": full, "deployment": deployment, **({"failed": ev.error} if ev.status != "ok" else {}),
            **({"warnings": warnings} if warnings else {})}


def _plain(recordings: Any) -> dict[str, dict[str, Any]]:
    return {name: dict(m) for name, m in recordings.items()}


def _preflight(objective: Any, source: Any) -> list[str]:
    """The objective's ``preflight`` (its data loaded and checked once), a ``ValueError`` as the
    :class:`ConfigError` naming its key; the warnings."""
    preflight = hook(objective, "preflight")
    if preflight is None:
        return []
    try:
        return list(preflight() or [])
    except ValueError as exc:
        key, _, rest = str(exc).partition(": ")
        if key.startswith("objective") and rest:
            raise ConfigError(source, key, rest) from None
        raise ConfigError(source, "objective", str(exc)) from None


def objective_on_data(objective: Any, data_file: str | Path,
                      run_dir: str | Path | None = None) -> tuple[Any, list[str]]:
    """``objective`` rebuilt on ``data_file``'s data (a YAML file, its ``data:`` block or the whole
    document) and that data's preflight warnings, with the objective's ``compare_fingerprint`` line when the
    data differs from the fingerprint stored in ``run_dir``. The data is loaded now, so a bad file is one
    :class:`ConfigError` line on ``data_file``, not a traceback from the scoring."""
    doc = read_yaml(data_file, "--data")
    data = doc.get("data", doc) if isinstance(doc, dict) and "data" in doc else doc
    with_data = hook(objective, "with_data")
    if with_data is None:
        raise ConfigError(data_file, "data", "this objective does not take other data")
    try:
        objective = with_data(data)
        preflight = hook(objective, "preflight")
        warnings = list(preflight() or []) if preflight is not None else []
        compare = hook(objective, "compare_fingerprint") if run_dir is not None else None
        line = compare(RunDir(run_dir).fingerprint()) if compare is not None else None
        warnings += [line] if line else []
    except ValueError as exc:
        raise ConfigError(data_file, "data", str(exc)) from None
    return objective, warnings
