"""Best parameters out of a run, in forms other projects import: YAML, JSON, Python, C header.

Every format carries the provenance (run id, fitness, objective, data, date). The C header holds
the parameters as named ``static const`` constants and, where the objective has them, look-up tables
(``export_tables(params) -> {name: {"table": 2-D array, "x_range": (lo, hi), "y_range": (lo, hi)}}``).
"""

from __future__ import annotations

import datetime as _dt
import json
from pathlib import Path
from typing import Any

import yaml

from tuner.export_formats import FORMATS, c_prefix, to_c, to_json, to_python, to_yaml

__all__ = ["export", "FORMATS", "provenance"]


def provenance(run_dir: Path) -> dict[str, Any]:
    run_dir = Path(run_dir)
    best = yaml.safe_load((run_dir / "best.yaml").read_text())
    meta = json.loads((run_dir / "meta.json").read_text())
    cfg = yaml.safe_load((run_dir / "config.yaml").read_text())
    obj = cfg.get("objective", {})
    return {
        "run": run_dir.name,
        "fitness": best.get("fitness"),
        "objective": {k: obj[k] for k in ("kind", "filter", "controller", "function", "metric") if k in obj},
        "data": obj.get("data", obj.get("profile")),
        "optimizer": meta.get("optimizer"),
        "seed": meta.get("seed"),
        "n_evals": meta.get("n_evals"),
        "git_commit": meta.get("git_commit", ""),
        "exported": _dt.datetime.now(_dt.UTC).strftime("%Y-%m-%dT%H:%M:%SZ"),
        "params": best["params"],
    }


def export(run_dir: str | Path, fmt: str, objective_tables: bool = True, prefix: str | None = None) -> str:
    """The best parameters of ``run_dir`` in format ``fmt`` (one of :data:`FORMATS`).

    ``prefix`` names the C identifiers (default: from the run's name, see
    :func:`tuner.export_formats.c_prefix`). With ``objective_tables`` the objective is rebuilt to add
    units, the sample rate and (C) look-up tables.
    """
    if fmt not in FORMATS:
        raise ValueError(f"unknown format {fmt!r}; allowed: {list(FORMATS)}")
    run_dir = Path(run_dir)
    doc = provenance(run_dir)
    obj = _objective(run_dir) if objective_tables else None
    doc.update(units=_units(run_dir, obj, doc["params"]), **_sample_rate(obj))
    if fmt == "yaml":
        return to_yaml(doc)
    if fmt == "json":
        return to_json(doc)
    if fmt == "python":
        return to_python(doc)
    tables = None
    fn = getattr(obj, "export_tables", None)
    if callable(fn):
        tables = fn(doc["params"])
    if prefix is None:
        meta = json.loads((run_dir / "meta.json").read_text())
        prefix = c_prefix(meta.get("name") or run_dir.name)
    return to_c(doc, prefix=c_prefix(prefix), tables=tables)


def _objective(run_dir: Path) -> Any:
    from objectives.registry import build_objective

    cfg = yaml.safe_load((run_dir / "config.yaml").read_text())
    try:
        return build_objective(dict(cfg["objective"]), Path(cfg.get("base_dir", run_dir)))
    except (ValueError, OSError, ImportError):  # parameters still export if the objective no longer builds
        return None


def _units(run_dir: Path, obj: Any, params: dict[str, Any]) -> dict[str, str]:
    """Unit of each parameter: the run's resolved space, else the objective's default space."""
    units: dict[str, str] = {}
    fn = getattr(obj, "default_space", None)
    if callable(fn):
        units.update({p.name: p.unit for p in fn().params if p.unit})
    cfg = yaml.safe_load((run_dir / "config.yaml").read_text()) or {}
    for name, spec in (cfg.get("parameters") or {}).items():
        if isinstance(spec, dict) and spec.get("unit"):
            units[name] = spec["unit"]
    return {k: units[k] for k in params if k in units}


def _sample_rate(obj: Any) -> dict[str, Any]:
    """``sample_rate_hz`` and a note: the recordings' rate (filters) or the controller period (closed loop)."""
    from objectives.attitude.data.recording import RecordingError

    if obj is None:
        return {"sample_rate_hz": None, "sample_rate_note": "objective not rebuilt"}
    sensors = getattr(obj, "_sensors", None)
    if sensors is not None and getattr(sensors, "Ts_s", None):
        return {"sample_rate_hz": 1.0 / float(sensors.Ts_s), "sample_rate_note": "controller period Ts_s"}
    recs_fn = getattr(obj, "recordings", None)
    if not callable(recs_fn):
        return {"sample_rate_hz": None, "sample_rate_note": "the objective gives no sample rate"}
    specs = getattr(obj, "train_specs", None) or []
    if specs and all(isinstance(sp, dict) and set(sp) == {"synthetic"} and "rate_hz" in (sp["synthetic"] or {})
                     for sp in specs):  # stated in the config: no need to generate the recordings
        rates = sorted({round(float(sp["synthetic"]["rate_hz"]), 3) for sp in specs})
    else:
        try:
            rates = sorted({round(1.0 / float(r.dt), 3) for r in recs_fn("train")})
        except (RecordingError, OSError, ValueError) as exc:
            return {"sample_rate_hz": None, "sample_rate_note": f"training data not readable: {exc}"}
    if not rates:
        return {"sample_rate_hz": None, "sample_rate_note": "no training recording"}
    if max(rates) - min(rates) > 1e-3 * max(rates):
        return {"sample_rate_hz": None, "sample_rate_note": "training recordings differ: "
                + ", ".join(f"{r:g} Hz" for r in rates)}
    return {"sample_rate_hz": rates[0], "sample_rate_note": "rate of the training recordings; per-sample "
            "parameters must be rescaled for another rate"}
