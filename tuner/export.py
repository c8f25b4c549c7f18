"""Best parameters out of a run, in forms other projects import: YAML, JSON, Python, C header.

Every format carries the complete deployed configuration (:mod:`tuner.deployment`): ``params`` holds
every value of the tuned filter or controller (searched, fixed and defaults), ``deployment`` says which
is which, their units, allowed choices, the sample rate and the settings that only served scoring
(``scoring``: never part of the exported system; e.g. a run scored from the ground-truth start exports
a filter that starts from the first acc/mag sample, and says so under ``notes``). Every format also
carries the provenance (run id, fitness, objective, data, date). The C header holds
the parameters as named ``static const`` constants and, where the objective has them, look-up tables.
What is said about the objective comes from the objective itself, through its optional hooks
(:class:`tuner.objective.TunableObjective`): ``describe()`` for the provenance and
``export_tables(params)`` for the tables (look-up tables with their input ranges, or matrices such
as the LQR gain K and the tracking matrices Nx, Nu: ``{name: {"table": array, "doc": text, "unit":
text, "x_range"/"y_range": (lo, hi) for look-up tables}}``), written in every format (``tables:``
in YAML/JSON, ``TABLES`` in Python, ``double[ny][nx]`` in C); an objective without them (or one that
no longer builds) exports its kind and the parameters only.
"""

from __future__ import annotations

import datetime as _dt
import math
from pathlib import Path
from typing import Any

from tuner.export_formats import FORMATS, c_prefix, to_c, to_json, to_python, to_yaml
from tuner.objective import hook
from tuner.trust import data_only
from tuner.verdict import defaults_verdict

__all__ = ["export", "FORMATS", "C_SOURCE", "provenance", "export_c", "verify_c", "objective_formats", "export_own"]

#: the format name of the tuned system itself as C99 source (the objective's ``export_c`` hook), and the names it
#: is also accepted under, each for the one kind of deployment it names (``Deployment.kind``)
C_SOURCE = "c-source"
C_SOURCE_ALIASES = {"c-filter": "filter", "c-controller": "closed_loop"}


def _build(run_dir: Path) -> tuple[Any, str]:
    """The run's objective and '', or None and why it does not build (moved data, a removed package, or code
    its config names: a plant module, an FMU, a ``kind: python`` callable, which no export loads and no
    command loads from inside the run directory, :mod:`tuner.trust`)."""
    from tuner.config import ConfigError
    from tuner.rundir import RunDir
    from tuner.setup import build_objective, run_config

    try:
        return build_objective(run_config(RunDir(run_dir))), ""
    except (ConfigError, ValueError, OSError, ImportError) as exc:  # parameters still export
        return None, str(exc)


def provenance(run_dir: Path, objective: Any = None) -> dict[str, Any]:
    """Run id, fitness, optimiser, seed, commit, parameters, and what the objective says of itself."""
    from tuner.rundir import RunDir

    rd = RunDir(run_dir)  # RunError naming the file if best.yaml/meta.json/config.yaml is missing or corrupt
    run_dir = rd.path
    best, meta, cfg = rd.best().to_doc(), rd.meta().to_dict(), rd.config()
    describe = hook(objective, "describe") if objective is not None else None
    desc = dict(describe()) if describe else {}
    rep = rd.repeats()
    chosen = rep.chosen_entry if rep is not None else None
    extra = {} if chosen is None else {"repeat": {"run": chosen.run, "of": rep.n, "chosen_by": rep.rule}}
    return {
        "run": run_dir.name,
        "fitness": best.get("fitness"),
        "objective": dict(desc.get("objective") or {"kind": cfg.get("objective", {}).get("kind")}),
        "data": desc.get("data"),
        "optimizer": meta.get("optimizer"),
        "seed": meta.get("seed") if chosen is None else chosen.seed,  # a repeated run deploys one seed's best
        "n_evals": meta.get("n_evals") if chosen is None else chosen.n_evals,
        **extra,
        "git_commit": meta.get("git_commit", ""),
        "exported": _dt.datetime.now(_dt.UTC).strftime("%Y-%m-%dT%H:%M:%SZ"),
        "params": best["params"],
        **({"warning": verdict} if (verdict := defaults_verdict(best.get("evaluation"))) else {}),
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
    with data_only("tuner export"):  # a run directory is data: no code its config names is loaded
        objective, why = _build(run_dir) if objective_tables else (None, "")
        doc = provenance(run_dir, objective)
        dep = _deployment(run_dir)
    units = _units(run_dir, objective, doc["params"])
    rate = _sample_rate(objective, why)
    if dep is not None:  # the complete deployed system: every value, scoring-only settings apart
        doc["params"] = dict(dep.values)
        doc["deployment"] = {k: v for k, v in dep.to_doc().items() if k not in ("values", "units", "docs", "tables")}
        units = {**dict(dep.units), **units}  # a unit written in the config wins
        if dep.sample_rate_hz is not None and rate["sample_rate_hz"] is None:
            rate = {"sample_rate_hz": dep.sample_rate_hz, "sample_rate_note": "recorded with the run"}
    doc.update(units={k: units[k] for k in doc["params"] if k in units}, **rate)
    fn = hook(objective, "export_tables") if objective is not None else None
    if dep is not None and dep.tables:  # as the run computed them (no objective, nor its code, needed)
        tables = {name: dict(t) for name, t in dep.tables.items()}
    else:
        tables = fn(doc["params"]) if fn is not None else None
    if fmt != "c":  # what firmware runs (LQR gain K, Nx, Nu; fuzzy LUTs) in every format, as nested lists
        if tables:
            doc["tables"] = {name: {k: v for k, v in t.items()} for name, t in tables.items()}
        return {"yaml": to_yaml, "json": to_json, "python": to_python}[fmt](doc)
    if prefix is None:
        from tuner.rundir import RunDir

        prefix = c_prefix(RunDir(run_dir).meta().name or run_dir.name)
    return to_c(doc, prefix=c_prefix(prefix), tables=tables)


def _deployment(run_dir: Path) -> Any:
    """The run's :class:`tuner.deployment.Deployment`, or None when ``best.yaml`` records none and the
    objective no longer builds (an older run: the parameters of ``best.yaml`` are exported then). A
    recorded but malformed deployment is a :class:`tuner.records.RunError` naming the file."""
    from tuner.deployment import load_deployment
    from tuner.records import RunError
    from tuner.rundir import RunDir

    if RunDir(run_dir).best().deployment:
        return load_deployment(run_dir)
    try:
        return load_deployment(run_dir)
    except RunError:
        return None


def _units(run_dir: Path, obj: Any, params: dict[str, Any]) -> dict[str, str]:
    """Unit of each parameter: the run's resolved space, else the objective's default space."""
    from tuner.rundir import RunDir

    units: dict[str, str] = {}
    fn = hook(obj, "default_space") if obj is not None else None
    if fn is not None:
        units.update({p.name: p.unit for p in fn().params if p.unit})
    for name, spec in (RunDir(run_dir).config().get("parameters") or {}).items():
        if isinstance(spec, dict) and spec.get("unit"):
            units[name] = spec["unit"]
    return {k: units[k] for k in params if k in units}


def _sample_rate(obj: Any, why: str = "") -> dict[str, Any]:
    """``sample_rate_hz`` and a note, from the objective's optional ``sample_rate()`` hook."""
    if obj is None:
        note = "objective not rebuilt" + (" (it names code, which an export never loads)" if "does not load" in why
                                          else "")
        return {"sample_rate_hz": None, "sample_rate_note": note}
    fn = hook(obj, "sample_rate")
    if fn is None:
        return {"sample_rate_hz": None, "sample_rate_note": "the objective gives no sample rate"}
    hz, note = fn()
    return {"sample_rate_hz": hz, "sample_rate_note": note}


def _deployed_objective(run_dir: Path, data_file: str | Path | None = None,
                        warnings: list[str] | None = None) -> tuple[Any, Any]:
    """The run's objective (on ``data_file``'s data when given, its warnings appended to ``warnings``) and its
    :class:`tuner.deployment.Deployment`."""
    from tuner.config import ConfigError
    from tuner.deployment import load_deployment
    from tuner.rescore import objective_on_data

    objective, why = _build(run_dir)
    if objective is None:
        raise ConfigError(run_dir / "config.yaml", "objective", f"does not build: {why}")
    if data_file:
        objective, found = objective_on_data(objective, data_file, run_dir)
        (warnings if warnings is not None else []).extend(found)
    return objective, load_deployment(run_dir)


def export_c(run_dir: str | Path, precision: str = "double", prefix: str | None = None,
             fmt: str = C_SOURCE) -> dict[str, str]:
    """``{filename: text}``: the C source of the run's deployed system (the objective's ``export_c`` hook: a
    filter, a controller), its header led by the run's provenance (run, fitness, optimiser, data, commit).

    ``fmt``: :data:`C_SOURCE`, or one of :data:`C_SOURCE_ALIASES`, which also requires its kind of deployment
    (``c-controller`` of a filter run is a ConfigError naming the config's objective)."""
    from tuner.config import ConfigError
    from tuner.rundir import RunDir

    run_dir = Path(run_dir)
    with data_only("tuner export"):  # a run directory is data: no code its config names is loaded
        objective, dep = _deployed_objective(run_dir)
    fn = hook(objective, "export_c")
    if fn is None:
        raise ConfigError(run_dir / "config.yaml", "objective", "this objective has no C export (hook export_c)")
    want = C_SOURCE_ALIASES.get(fmt)
    if want is not None and dep.kind != want:
        other = [k for k, v in C_SOURCE_ALIASES.items() if v == dep.kind]
        raise ConfigError(run_dir / "config.yaml", "objective",
                          f"--format {fmt} exports a {want.replace('_', '-')} objective's result; this run's is "
                          f"{dep.kind!r}: use --format {other[0] if other else C_SOURCE}")
    doc = provenance(run_dir, objective)
    if prefix is None:
        prefix = c_prefix(RunDir(run_dir).meta().name or run_dir.name)
    lines = [f"run: {doc['run']}", f"fitness: {doc['fitness']!r} ({(doc['objective'] or {}).get('metric', '')})",
             f"optimizer: {doc['optimizer']}, seed {doc['seed']}, {doc['n_evals']} evaluations",
             f"data: {doc['data']}", f"git commit: {doc['git_commit']}", f"exported: {doc['exported']}"]
    try:
        return dict(fn(dict(dep.values), precision, c_prefix(prefix), "\n".join(lines)))
    except ValueError as exc:
        raise _hook_error(run_dir, exc) from None


def objective_formats(run_dir: str | Path) -> dict[str, str]:
    """``{format: help}`` of the run's objective's own formats (hook ``export_formats``; empty when it has none or
    no longer builds)."""
    objective, _ = _build(Path(run_dir))
    fn = hook(objective, "export_formats") if objective is not None else None
    return dict(fn()) if fn is not None else {}


def export_own(run_dir: str | Path, fmt: str) -> str:
    """The deployed system in the objective's own format ``fmt`` (hook ``export_as``), led by the run's provenance
    and scores (run, fitness, held-out and CV scores when recorded, optimiser, data, commit).

    Raises ConfigError naming ``best.yaml``'s deployment for a value the format cannot express, and the config's
    objective when the objective has no such format.
    """
    from tuner.config import ConfigError
    from tuner.rundir import RunDir

    run_dir = Path(run_dir)
    objective, dep = _deployed_objective(run_dir)
    own = objective_formats(run_dir)
    if fmt not in own:
        raise ConfigError(run_dir / "config.yaml", "objective", f"no export format {fmt!r}; this objective's own: "
                          f"{', '.join(own) or 'none'}; the engine's: {', '.join([*FORMATS, C_SOURCE])}")
    doc = provenance(run_dir, objective)
    best = RunDir(run_dir).best().to_doc()
    scores = {k: v for k, v in (best.get("evaluation") or {}).items()
              if k.endswith("_fitness") and isinstance(v, (int, float))}
    worse = [f"{w} {scores[f'{w}_fitness']:.6g} against the defaults' {scores[f'defaults_{w}_fitness']:.6g}"
             for w in ("cv", "test") if scores.get(f"{w}_fitness", -math.inf) > scores.get(f"defaults_{w}_fitness",
                                                                                          math.inf)]
    lines = [f"run: {doc['run']}", f"fitness: {doc['fitness']!r} ({(doc['objective'] or {}).get('metric', '')})",
             *(f"{k}: {v!r}" for k, v in sorted(scores.items())),
             *([f"note: on data the tuning did not see the defaults score better ({'; '.join(worse)})"] if worse
               else []),
             f"optimizer: {doc['optimizer']}, seed {doc['seed']}, {doc['n_evals']} evaluations",
             f"data: {doc['data']}", f"git commit: {doc['git_commit']}", f"exported: {doc['exported']}"]
    try:
        return hook(objective, "export_as")(fmt, dict(dep.values), "\n".join(lines))
    except ValueError as exc:
        raise ConfigError(run_dir / "best.yaml", "deployment", str(exc)) from None


def verify_c(run_dir: str | Path, data_file: str | Path | None = None, precision: str = "double",
             opt: tuple[str, ...] = ("-O2",)) -> dict[str, Any]:
    """The run's exported C compiled and scored next to the model: the objective's ``verify_c`` hook's result
    and ``name``, the deployed system's name."""
    from tuner.config import ConfigError

    run_dir = Path(run_dir)
    warnings: list[str] = []
    objective, dep = _deployed_objective(run_dir, data_file, warnings)
    fn = hook(objective, "verify_c")
    if fn is None:
        raise ConfigError(run_dir / "config.yaml", "objective", "this objective has no C export to verify "
                          "(hook verify_c)")
    try:
        return {"name": dep.name, **dict(fn(dict(dep.values), precision, tuple(opt))),
                **({"warnings": warnings} if warnings else {})}
    except ValueError as exc:
        raise _hook_error(run_dir, exc) from None


def _hook_error(run_dir: Path, exc: ValueError) -> Exception:
    """A C hook's ValueError as a ConfigError: one naming a key of the config's objective (``objective.x: ...``,
    e.g. a controller without a C port) names the config, any other the deployed values of ``best.yaml``."""
    from tuner.config import ConfigError

    text = str(exc)
    key, sep, rest = text.partition(": ")
    if sep and key.startswith("objective.") and " " not in key:
        return ConfigError(run_dir / "config.yaml", key, rest)
    return ConfigError(run_dir / "best.yaml", "deployment", text)
