"""Best parameters out of a run, in forms other projects import: YAML, JSON, Python, C header.

Every format carries the provenance (run id, fitness, objective, data, date). The C header holds
the parameters as named ``static const`` constants and, where the objective has them, look-up tables.
What is said about the objective comes from the objective itself, through its optional hooks
(:class:`tuner.objective.TunableObjective`): ``describe()`` for the provenance and
``export_tables(params)`` for the tables; an objective without them (or one that no longer builds)
exports its kind and the parameters only.
"""

from __future__ import annotations

import datetime as _dt
import json
import math
import re
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from tuner.objective import hook

__all__ = ["export", "FORMATS", "provenance"]

FORMATS = ("yaml", "json", "python", "c")


def _build(run_dir: Path) -> Any:
    """The run's objective, or None when it no longer builds (moved data, removed package...)."""
    from tuner.registry import build_objective
    from tuner.rundir import RunDir

    cfg = RunDir(run_dir).config()
    try:
        return build_objective(dict(cfg["objective"]), Path(cfg.get("base_dir", run_dir)))
    except (ValueError, OSError, ImportError):  # parameters still export if the objective no longer builds
        return None


def provenance(run_dir: Path, objective: Any = None) -> dict[str, Any]:
    """Run id, fitness, optimiser, seed, commit, parameters, and what the objective says of itself."""
    from tuner.rundir import RunDir

    rd = RunDir(run_dir)  # RunError naming the file if best.yaml/meta.json/config.yaml is missing or corrupt
    run_dir = rd.path
    best, meta, cfg = rd.best().to_doc(), rd.meta().to_dict(), rd.config()
    describe = hook(objective, "describe") if objective is not None else None
    desc = dict(describe()) if describe else {}
    return {
        "run": run_dir.name,
        "fitness": best.get("fitness"),
        "objective": dict(desc.get("objective") or {"kind": cfg.get("objective", {}).get("kind")}),
        "data": desc.get("data"),
        "optimizer": meta.get("optimizer"),
        "seed": meta.get("seed"),
        "n_evals": meta.get("n_evals"),
        "git_commit": meta.get("git_commit", ""),
        "exported": _dt.datetime.now(_dt.UTC).strftime("%Y-%m-%dT%H:%M:%SZ"),
        "params": best["params"],
    }


def _c_ident(name: str) -> str:
    s = re.sub(r"[^0-9A-Za-z_]", "_", name).upper()
    return s if not s[0].isdigit() else f"P_{s}"


def _c_number(v: float) -> str:
    if isinstance(v, bool):
        return "1" if v else "0"
    if isinstance(v, int):
        return str(v)
    if not math.isfinite(v):
        raise ValueError(f"cannot write non-finite value {v} into a C header")
    return repr(float(v))


def to_c(doc: dict[str, Any], prefix: str = "TUNER", tables: dict[str, Any] | None = None) -> str:
    guard = f"{prefix}_{_c_ident(doc['run'])}_H"
    lines = [
        f"/* Tuned parameters exported by tuner from run {doc['run']}.",
        f" * fitness {doc['fitness']!r}; optimizer {doc['optimizer']}; seed {doc['seed']};",
        f" * objective {json.dumps(doc['objective'])};",
        f" * exported {doc['exported']}; commit {doc['git_commit'] or 'unknown'}. */",
        f"#ifndef {guard}", f"#define {guard}", "",
    ]
    for name, v in doc["params"].items():
        ident = f"{prefix}_{_c_ident(name)}"
        if isinstance(v, bool) or isinstance(v, (int, float)):
            ctype = "int" if isinstance(v, (bool, int)) else "double"
            lines.append(f"static const {ctype} {ident} = {_c_number(v)};")
        elif isinstance(v, str):
            lines.append(f'static const char {ident}[] = {json.dumps(v)};')
        elif isinstance(v, (list, tuple)) and all(isinstance(x, (int, float)) for x in v):
            vals = ", ".join(_c_number(float(x)) for x in v)
            lines.append(f"static const double {ident}[{len(v)}] = {{{vals}}};")
        else:
            lines.append(f"/* {name}: {v!r} has no C form */")
    for name, t in (tables or {}).items():
        ident = f"{prefix}_{_c_ident(name)}"
        arr = np.asarray(t["table"], float)
        ny, nx = arr.shape
        lines += ["", f"/* look-up table {name}: rows follow y, columns follow x */",
                  f"#define {ident}_NX {nx}", f"#define {ident}_NY {ny}",
                  f"static const double {ident}_X_MIN = {_c_number(float(t['x_range'][0]))};",
                  f"static const double {ident}_X_MAX = {_c_number(float(t['x_range'][1]))};",
                  f"static const double {ident}_Y_MIN = {_c_number(float(t['y_range'][0]))};",
                  f"static const double {ident}_Y_MAX = {_c_number(float(t['y_range'][1]))};",
                  f"static const double {ident}[{ny}][{nx}] = {{"]
        for row in arr:
            lines.append("    {" + ", ".join(_c_number(float(x)) for x in row) + "},")
        lines.append("};")
    lines += ["", f"#endif /* {guard} */", ""]
    return "\n".join(lines)


def to_python(doc: dict[str, Any]) -> str:
    lines = [f'"""Tuned parameters from tuner run {doc["run"]} (fitness {doc["fitness"]!r})."""', "",
             f"PROVENANCE = {doc_repr({k: v for k, v in doc.items() if k != 'params'})}", "",
             f"PARAMS = {doc_repr(doc['params'])}", ""]
    return "\n".join(lines)


def doc_repr(d: Any) -> str:
    return repr(json.loads(json.dumps(d)))


def export(run_dir: str | Path, fmt: str, objective_tables: bool = True) -> str:
    """The best parameters of ``run_dir`` in format ``fmt`` (one of :data:`FORMATS`)."""
    if fmt not in FORMATS:
        raise ValueError(f"unknown format {fmt!r}; allowed: {list(FORMATS)}")
    objective = _build(Path(run_dir))
    doc = provenance(Path(run_dir), objective)
    if fmt == "yaml":
        return yaml.safe_dump(doc, sort_keys=False)
    if fmt == "json":
        return json.dumps(doc, indent=2)
    if fmt == "python":
        return to_python(doc)
    tables = None
    fn = hook(objective, "export_tables") if objective is not None and objective_tables else None
    if fn is not None:
        tables = fn(doc["params"])
    return to_c(doc, tables=tables)
