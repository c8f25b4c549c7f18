"""Scoring without tuning: ``tuner evaluate CONFIG_OR_RUN_DIR [--params P.yaml] [--data D.yaml]``.

The parameters default to the run's best (for a run directory) or to the objective's defaults
(for a config). ``--data`` replaces the config's data with another list of data specs (or a
``{train, test}`` mapping), which is how tuned parameters are checked on new recordings.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import yaml

from tuner.config import ConfigError, config_from_dict, load_config, read_yaml

__all__ = ["evaluate_target"]


def evaluate_target(target: str | Path, params_file: str | Path | None = None,
                    data_file: str | Path | None = None) -> dict[str, Any]:
    """``{"fitness": float, "recordings": {name: {metric: value}}, "params": {...}}`` (plus test scores)."""
    from objectives.registry import build_objective

    target = Path(target)
    best_params = None
    if target.is_dir():
        if not (target / "config.yaml").exists():
            raise ConfigError(target, "", "not a run directory (no config.yaml)")
        raw = yaml.safe_load((target / "config.yaml").read_text())
        source, base_dir = raw.pop("source", str(target / "config.yaml")), Path(raw.pop("base_dir", target))
        cfg = config_from_dict(raw, source=source, base_dir=base_dir)
        if (target / "best.yaml").exists():
            best_params = yaml.safe_load((target / "best.yaml").read_text())["params"]
    else:
        cfg = load_config(target)
    try:
        objective = build_objective(dict(cfg.objective), cfg.base_dir)
    except ValueError as exc:
        raise ConfigError(cfg.source, "objective", str(exc)) from None
    space = cfg.space(objective)
    if params_file:
        doc = read_yaml(params_file, "--params")
        params = dict(doc.get("params", doc)) if isinstance(doc, dict) else None
        if params is None:
            raise ConfigError(params_file, "", "expected a mapping of parameters (or a best.yaml)")
    elif best_params is not None:
        params = best_params
    else:
        defaults = getattr(getattr(objective, "_cls", None), "defaults", None)
        if defaults is None:
            raise ConfigError(target, "", "no parameters: give --params (a config has no best)")
        params = {k: v for k, v in defaults.items() if k in space}
    full = {**space.fixed, **params}
    missing = [n for n in space.free_names if n not in full]
    if missing:
        raise ConfigError(params_file or target, "params", f"missing value(s) for {missing}")
    if data_file:
        doc = read_yaml(data_file, "--data")
        data = doc.get("data", doc) if isinstance(doc, dict) and "data" in doc else doc
        if not hasattr(objective, "with_data"):
            raise ConfigError(data_file, "data", "this objective does not take other data")
        try:
            objective = objective.with_data(data)
        except ValueError as exc:
            raise ConfigError(data_file, "data", str(exc)) from None
    if hasattr(objective, "score"):
        s = objective.score(full, "train")
        out = {"fitness": s["fitness"], "recordings": s["recordings"], "params": full}
        if s.get("failed"):
            out["failed"] = s["failed"]
        if not data_file and getattr(objective, "test_specs", None):
            t = objective.score(full, "test")
            out["test_fitness"] = t["fitness"]
            out["test_recordings"] = t["recordings"]
        return out
    from tuner.evaluate import evaluate_one

    rec = evaluate_one(objective, full)
    ev = rec.evaluation
    return {"fitness": ev.fitness if ev.status == "ok" else math.nan, "recordings": {"all": dict(ev.metrics)},
            "params": full, **({"failed": ev.error} if ev.status != "ok" else {})}
