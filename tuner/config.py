"""Job configuration: YAML into typed, validated dataclasses.

Every error is a :class:`ConfigError` that names the file, the key path, the bad value and what is
allowed; the CLI prints it and exits with status 2.

Shape of a job (see README for every key)::

    name: my-job
    seed: 7
    objective: {kind: filter, ...}            # validated by the objective's own factory
    parameters: {beta: {low: 0.001, high: 1, scale: log}}   # optional: the objective's default space
    optimizer: {method: pso, population: 30, generations: 30, <method options>,
                refine: {stages: 2, shrink: 0.2}}
    parallel: {backend: loky, n_jobs: 2, address: null}
    output: runs                              # parent directory of run directories
    repeats: 5                                # optional: 5 runs, seeds seed + 0..4 (tuner.repeats)
    validation: {cv: logo, select: {top_k: 5, holdout: 0.25, include_defaults: true}}   # optional, see ValidationConfig
"""

from __future__ import annotations

import copy
import re
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml

from tuner import safe_yaml
from tuner.objective import hook
from tuner.space import Real, Space, SpaceError

__all__ = ["ConfigError", "RunConfig", "OptimizerConfig", "ParallelConfig", "RefineConfig", "ValidationConfig",
           "SelectConfig", "load_config", "read_yaml", "config_from_dict", "apply_overrides"]

TOP_KEYS = {
    "name": "job name (used in the run directory name)",
    "description": "free text",
    "seed": "integer seed of the run",
    "objective": "what to minimise: {kind: function|filter|closed_loop|python, ...}",
    "parameters": "search space: {name: {low, high, scale, integer} | {fixed: value}}",
    "optimizer": "{method: pso|cmaes|de|random, population, generations, ...options}",
    "parallel": "{backend: serial|loky|dask|threads, n_jobs, address}",
    "output": "directory holding the run directories (default: runs)",
    "repeats": "number of runs of this job, seeds seed + 0 .. seed + repeats - 1 (default: 1)",
    "validation": "{cv: logo|kfold|dataset|none or {by, folds}, folds, budget_fraction, gap_warn_rel, "
                  "gap_warn_abs, "
                  "select: {top_k, holdout, include_defaults}, chosen_on: text}",
}


class ConfigError(ValueError):
    """A bad configuration: ``file: key.path: message``."""

    def __init__(self, file: str | Path | None, key: str, message: str):
        self.file, self.key, self.message = (str(file) if file else "<config>"), key, message
        super().__init__(f"{self.file}: {key}: {message}" if key else f"{self.file}: {message}")

    def __reduce__(self):  # raised in a worker process (a parallel sweep's job), it must unpickle in the parent
        return type(self), (self.file, self.key, self.message)


_INPROC = re.compile(r"inproc://\S+")  # a scheduler in this process (a LocalCluster without processes)
_ADDRESS = re.compile(r"(tcp|tls|ucx|ws|wss)://(\[[0-9A-Fa-f:.]+\]|[A-Za-z0-9][A-Za-z0-9.-]*):[0-9]{1,5}")

#: the largest population or number of generations accepted (more would exhaust memory before the first
#: generation, or take longer than any run: a typo such as 1e12)
MAX_COUNT = 1_000_000
#: the most repeats of one job (each is a whole run with a directory of its own)
MAX_REPEATS = 1000


@dataclass(frozen=True)
class RefineConfig:
    """Multi-stage refinement: after each stage the bounds shrink around the best point."""

    stages: int = 1
    shrink: float = 0.2


@dataclass(frozen=True)
class OptimizerConfig:
    method: str = "pso"
    population: int | None = None
    generations: int | None = None
    options: Mapping[str, Any] = field(default_factory=dict)
    refine: RefineConfig = field(default_factory=RefineConfig)


@dataclass(frozen=True)
class ParallelConfig:
    backend: str = "loky"
    n_jobs: int = 2
    address: str | None = None
    connect_timeout_s: float = 30.0  # how long to wait for the Dask scheduler at ``address``


@dataclass(frozen=True)
class SelectConfig:
    """Final choice by a validation fold: the ``top_k`` distinct best candidates of the tuning history
    are rescored on the held-out recordings ``holdout`` (a fold name of the objective's ``cv_folds``,
    e.g. a BROAD group, or a fraction ``f`` in (0, 0.5]: fold 0 of ``round(1 / f)``-fold); the run
    tunes on the rest.

    ``include_defaults`` (default true) adds the objective's default values of the searched parameters
    (its ``default_params`` hook, not clipped to the search bounds) as one more candidate on the held-out
    fold, so the final choice is the untuned objective when that does better there. It is on by default
    because a choice among tuned candidates alone can be worse than the untuned objective on new data,
    which a held-out fold is there to catch; it costs one evaluation on each side of the split."""

    top_k: int = 5
    holdout: str | float = 0.25
    include_defaults: bool = True


@dataclass(frozen=True)
class ValidationConfig:
    """The ``validation:`` section (all optional; absent = no validation, the run as before).

    cv : ``None`` (no CV), ``"logo"`` (the objective's own folds, e.g. BROAD's groups, else 5-fold),
        ``"kfold"`` (``folds`` folds) or ``"dataset"`` (leave one dataset out: the objective's ``cv_folds(k,
        by="dataset")``, e.g. the ``dataset:`` labels of its data sources): cross-validation after the run,
        written into the run directory. YAML: ``cv: logo`` or ``cv: {by: dataset}`` (``{by: kfold, folds: 5}``).
    folds : folds of ``kfold`` (>= 2).
    budget_fraction : generations (and ``max_evals``) of each fold's tuning relative to the run's, in (0, 1].
    gap_warn_rel, gap_warn_abs : the gap (CV score - tuning score) is *large* when it exceeds
        ``gap_warn_rel * |tuning score|`` or, when given, ``gap_warn_abs`` (fitness units, e.g. 0.6 deg).
    select : :class:`SelectConfig` or ``None``.
    chosen_on : the data the config's fixed options and search ranges were chosen on by looking at it, when
        that is the run's own data; the report then says the CV (which re-tunes only the searched values) is
        optimistic (:func:`tuner.verdict.optimistic_note`). A declaration, not a setting: nothing else changes.
    nested : with ``cv: {..., nested: {choose: {option: [a, b]}}}`` the CV chooses those fixed options inside
        each fold (:mod:`tuner.nested`: the inner loop chooses, the outer scores).
    """

    cv: str | None = None
    folds: int | None = None
    budget_fraction: float = 1.0
    gap_warn_rel: float = 0.25
    gap_warn_abs: float | None = None
    select: SelectConfig | None = None
    chosen_on: str | None = None
    nested: Mapping[str, tuple] | None = None  # cv: {nested: {choose: {option: [a, b]}}} (tuner.nested)

    @property
    def active(self) -> bool:
        return self.cv is not None or self.select is not None

    def gap_is_large(self, gap: float, tuning: float) -> bool:
        """True when ``gap`` exceeds the relative or the absolute threshold (a NaN gap is not large)."""
        if not gap == gap:
            return False
        return gap > self.gap_warn_rel * abs(tuning) or (self.gap_warn_abs is not None and gap > self.gap_warn_abs)

    def gap_rule(self) -> str:
        """The rule in words, for reports."""
        rel = f"> {self.gap_warn_rel:.0%} of the tuning score"
        return rel + (f" or > {self.gap_warn_abs:g}" if self.gap_warn_abs is not None else "")


@dataclass(frozen=True)
class RunConfig:
    """A validated job. ``raw`` is the resolved YAML mapping written into the run directory. ``origin`` is the
    run (or sweep) directory the config was read back from (:func:`tuner.setup.run_config`), None for a config
    file: no code is loaded from inside it (:func:`tuner.trust.code_outside`)."""

    name: str
    seed: int
    objective: Mapping[str, Any]
    parameters: Mapping[str, Any] | None
    optimizer: OptimizerConfig
    parallel: ParallelConfig
    output: str
    source: str
    base_dir: Path
    raw: Mapping[str, Any]
    description: str = ""
    validation: ValidationConfig = field(default_factory=ValidationConfig)
    origin: Path | None = None
    repeats: int = 1

    def space(self, objective: Any = None) -> Space:
        """The search space: ``parameters`` if given, else the objective's ``default_space()``.

        A parameter written without ``unit`` or ``doc`` takes them from the objective's declaration (so
        that reports and exports show the unit however the bounds were written).
        """
        default_space = hook(objective, "default_space") if objective is not None else None
        if self.parameters is not None:
            try:
                space = Space.from_dict(self.parameters)
            except SpaceError as exc:
                raise ConfigError(self.source, "parameters", str(exc)) from None
            declared = default_space() if default_space is not None else None
            if declared is None:
                return space
            return Space([Real.from_dict(p.name, {**p.to_dict(), "unit": p.unit or declared[p.name].unit,
                                                  "doc": p.doc or declared[p.name].doc})
                          if p.name in declared else p for p in space.params])
        if default_space is not None:
            return default_space()
        raise ConfigError(self.source, "parameters", "missing: this objective has no default search space")


def _type_name(t: Any) -> str:
    return t.__name__ if isinstance(t, type) else " or ".join(x.__name__ for x in t)


def _get(d: Mapping, key: str, types: Any, file: Any, path: str, default: Any = None, required=False):
    if key not in d or d[key] is None:
        if required:
            raise ConfigError(file, f"{path}{key}", "missing (required)")
        return default
    v = d[key]
    if isinstance(v, bool) and bool not in (types if isinstance(types, tuple) else (types,)):
        raise ConfigError(file, f"{path}{key}", f"expected {_type_name(types)}, got {v!r}")
    if not isinstance(v, types):
        raise ConfigError(file, f"{path}{key}", f"expected {_type_name(types)}, got {type(v).__name__} {v!r}")
    return v


def parse_value(text: str) -> Any:
    """A ``--set`` value: YAML scalar/flow syntax (``3``, ``1e-3``, ``true``, ``[1, 2]``, ``{a: 1}``)."""
    try:
        return safe_yaml.load(text)
    except yaml.YAMLError:
        return text


def apply_overrides(raw: dict[str, Any], overrides: list[str], file: Any = None) -> dict[str, Any]:
    """Apply ``key.path=value`` overrides (creating intermediate mappings)."""
    raw = copy.deepcopy(raw)
    for item in overrides:
        if "=" not in item:
            raise ConfigError(file, "--set", f"expected key.path=value, got {item!r}")
        path, text = item.split("=", 1)
        keys = path.strip().split(".")
        node = raw
        for k in keys[:-1]:
            if not isinstance(node.get(k), dict):
                node[k] = {}
            node = node[k]
        node[keys[-1]] = parse_value(text)
    return raw


def read_yaml(path: str | Path, what: str = "") -> Any:
    """Parse a YAML file; a missing file or bad YAML is a :class:`ConfigError` naming the file."""
    path = Path(path)
    label = f"{what + ': ' if what else ''}"
    if not path.exists():
        raise ConfigError(path, "", f"{label}file not found")
    if path.is_dir():
        raise ConfigError(path, "", f"{label}is a directory; expected a YAML file")
    try:
        text = path.read_bytes().decode("utf-8")
    except UnicodeDecodeError:
        raise ConfigError(path, "", f"{label}not a text file (not UTF-8); expected a YAML file") from None
    except OSError as exc:
        raise ConfigError(path, "", f"{label}cannot read: {exc.strerror or exc}") from None
    if "\x00" in text:
        raise ConfigError(path, "", f"{label}is a binary file; expected a YAML file")
    try:
        return safe_yaml.load(text)
    except yaml.YAMLError as exc:
        raise ConfigError(path, "", f"{label}not valid YAML: {safe_yaml.one_line(exc)}") from None


def load_config(path: str | Path, overrides: list[str] | None = None, seed: int | None = None,
                n_jobs: int | None = None, repeats: int | None = None) -> RunConfig:
    """Read and validate a job file; ``overrides`` are ``key.path=value`` strings (``--set``); ``seed``,
    ``n_jobs`` and ``repeats`` replace the file's values (``--seed``, ``--n-jobs``, ``--repeats``)."""
    path = Path(path)
    raw = read_yaml(path)
    if not isinstance(raw, dict):
        raise ConfigError(path, "", f"expected a mapping at the top level, got {type(raw).__name__}")
    raw = apply_overrides(raw, overrides or [], path)
    if seed is not None:
        raw["seed"] = int(seed)
    if n_jobs is not None:
        par = raw.get("parallel") or {}
        if not isinstance(par, dict):
            raise ConfigError(path, "parallel", f"expected a mapping, got {type(par).__name__} {par!r}")
        raw["parallel"] = {**par, "n_jobs": int(n_jobs)}
    if repeats is not None:
        raw["repeats"] = repeats
    return config_from_dict(raw, source=str(path), base_dir=path.resolve().parent)


def optimizer_options(population: int | None, generations: int | None, options: Mapping[str, Any]) -> dict[str, Any]:
    """The keyword options an optimiser is built with (``population`` only when given)."""
    return {**options, **({} if population is None else {"population": population}), "generations": generations}


def check_optimizer_options(f: Any, method: str, options: Mapping[str, Any], dim: int | None = None) -> None:
    """``options`` checked against the optimiser's declaration (:meth:`tuner.optimizers.base.Optimizer.check_options`;
    the rules needing the dimension when ``dim`` is given); a bad one is a :class:`ConfigError` naming it."""
    from tuner.optimizers import OPTIMIZERS, OptionError

    try:
        OPTIMIZERS[method].check_options(options, dim)
    except OptionError as exc:
        raise ConfigError(f, f"optimizer.{exc.key}" if exc.key else "optimizer",
                          f"invalid for {method}: {exc.message}") from None


def _number(d: Mapping, key: str, f: Any, path: str, low: float, high: float, default: Any,
            low_open: bool = False) -> Any:
    v = _get(d, key, (int, float), f, path, default=default)
    if v is None:
        return None
    ok = (low < v if low_open else low <= v) and v <= high
    if not ok or v != v:
        lo = "(" if low_open else "["
        raise ConfigError(f, f"{path}{key}", f"expected a number in {lo}{low:g}, {high:g}], got {v!r}")
    return float(v)


CV_KINDS = ("logo", "kfold", "dataset")


def parse_validation(raw: Any, f: Any) -> ValidationConfig:
    """The ``validation:`` section (see :class:`ValidationConfig`); errors name ``validation.<key>``."""
    if raw is None:
        return ValidationConfig()
    if not isinstance(raw, Mapping):
        raise ConfigError(f, "validation", f"expected a mapping, got {type(raw).__name__} {raw!r}")
    allowed = ("cv", "folds", "budget_fraction", "gap_warn_rel", "gap_warn_abs", "select", "chosen_on")
    bad = sorted(set(raw) - set(allowed))
    if bad:
        raise ConfigError(f, f"validation.{bad[0]}", f"unknown key; allowed: {', '.join(allowed)}")
    cv = raw.get("cv")
    raw = dict(raw)
    nested = None
    if isinstance(cv, Mapping):  # cv: {by: logo | kfold | dataset, folds: k, nested: {choose: {...}}}
        bad = sorted(set(cv) - {"by", "folds", "nested"})
        if bad:
            raise ConfigError(f, f"validation.cv.{bad[0]}", "unknown key; allowed: by, folds, nested")
        if "nested" in cv:
            nested = _parse_nested(cv["nested"], f)
        if "folds" in cv:
            if "folds" in raw:
                raise ConfigError(f, "validation.cv.folds", "given twice (also validation.folds); keep one")
            raw["folds"] = cv["folds"]
        if cv.get("by") not in CV_KINDS:
            raise ConfigError(f, "validation.cv.by", f"expected one of {', '.join(CV_KINDS)}, got {cv.get('by')!r}")
        cv = cv["by"]
    if cv is False or cv == "none":
        cv = None
    if cv is not None and cv not in CV_KINDS:
        raise ConfigError(f, "validation.cv", f"expected {', '.join(CV_KINDS)} or none (or {{by: ...}}), "
                          f"got {cv!r}")
    folds = _get(raw, "folds", int, f, "validation.", default=None)
    if folds is not None and folds < 2:
        raise ConfigError(f, "validation.folds", f"must be >= 2, got {folds}")
    if cv == "kfold" and folds is None:
        raise ConfigError(f, "validation.folds", "missing: cv: kfold needs the number of folds (>= 2)")
    if folds is not None and cv != "kfold":
        raise ConfigError(f, "validation.folds", f"only used with cv: kfold (cv is {cv!r})")
    frac = _number(raw, "budget_fraction", f, "validation.", 0.0, 1.0, 1.0, low_open=True)
    rel = _number(raw, "gap_warn_rel", f, "validation.", 0.0, float("inf"), 0.25)
    gabs = _number(raw, "gap_warn_abs", f, "validation.", 0.0, float("inf"), None)
    sel_raw = raw.get("select")
    select = None
    if sel_raw is not None:
        if not isinstance(sel_raw, Mapping):
            raise ConfigError(f, "validation.select", f"expected a mapping {{top_k, holdout, include_defaults}}, "
                              f"got {sel_raw!r}")
        bad = sorted(set(sel_raw) - {"top_k", "holdout", "include_defaults"})
        if bad:
            raise ConfigError(f, f"validation.select.{bad[0]}",
                              "unknown key; allowed: top_k, holdout, include_defaults")
        top_k = _get(sel_raw, "top_k", int, f, "validation.select.", default=5)
        if top_k < 2:
            raise ConfigError(f, "validation.select.top_k", f"must be >= 2 (a choice among candidates), got {top_k}")
        holdout = _get(sel_raw, "holdout", (str, int, float), f, "validation.select.", default=0.25)
        if not isinstance(holdout, str) and not 0 < holdout <= 0.5:
            raise ConfigError(f, "validation.select.holdout", "expected a fold name (e.g. a BROAD group) or a "
                              f"fraction in (0, 0.5], got {holdout!r}")
        with_defaults = _get(sel_raw, "include_defaults", bool, f, "validation.select.", default=True)
        select = SelectConfig(top_k, holdout if isinstance(holdout, str) else float(holdout), with_defaults)
    chosen_on = raw.get("chosen_on")
    if chosen_on is not None and (not isinstance(chosen_on, str) or not chosen_on.strip()):
        raise ConfigError(f, "validation.chosen_on", "expected a text naming the data the config's fixed options "
                          f"and ranges were chosen on (e.g. 'the 16 shared BROAD trials'), got {chosen_on!r}")
    return ValidationConfig(cv, folds, frac, rel, gabs, select, chosen_on, nested)


#: at most this many combinations of nested choices (each one more tuning per outer fold)
MAX_NESTED = 16


def _parse_nested(raw: Any, f: Any) -> dict[str, tuple]:
    """``nested: {choose: {option: [a, b], ...}}`` -> ``{option: (a, b)}`` (errors name the key)."""
    key = "validation.cv.nested"
    if not isinstance(raw, Mapping) or set(raw) != {"choose"}:
        raise ConfigError(f, key, f"expected {{choose: {{option: [value, value, ...]}}}}, got {raw!r}")
    choose = raw["choose"]
    if not isinstance(choose, Mapping) or not choose:
        raise ConfigError(f, f"{key}.choose", f"expected a mapping of options to candidate lists, got {choose!r}")
    out: dict[str, tuple] = {}
    n = 1
    for name, values in choose.items():
        if not isinstance(values, (list, tuple)) or len(values) < 2 or len(set(map(repr, values))) != len(values):
            raise ConfigError(f, f"{key}.choose.{name}", f"expected a list of >= 2 distinct candidate values, "
                              f"got {values!r}")
        out[str(name)] = tuple(values)
        n *= len(values)
    if n > MAX_NESTED:
        raise ConfigError(f, f"{key}.choose", f"{n} combinations; at most {MAX_NESTED} (each is one more tuning "
                          "per fold)")
    return out


def config_from_dict(raw: Mapping[str, Any], source: str = "<config>", base_dir: Path | None = None) -> RunConfig:
    """Validate a job mapping (see module docstring)."""
    from tuner.optimizers import OPTIMIZERS

    f = source
    raw = copy.deepcopy(dict(raw))
    unknown = sorted(set(raw) - set(TOP_KEYS))
    if unknown:
        allowed = ", ".join(sorted(TOP_KEYS))
        raise ConfigError(f, unknown[0], f"unknown key; allowed top-level keys: {allowed}")
    name = str(_get(raw, "name", (str, int), f, "", default=Path(source).stem or "job"))
    if not name.replace("-", "").replace("_", "").replace(".", "").isalnum():
        raise ConfigError(f, "name", f"use letters, digits, '-', '_' or '.', got {name!r}")
    seed = _get(raw, "seed", int, f, "", default=0)
    if seed < 0:
        raise ConfigError(f, "seed", f"must be >= 0, got {seed}")
    objective = _get(raw, "objective", dict, f, "", required=True)
    if "kind" not in objective:
        raise ConfigError(f, "objective.kind", "missing; one of function, filter, closed_loop, python")
    timeout_s = objective.get("timeout_s")
    if timeout_s is not None and (isinstance(timeout_s, bool) or not isinstance(timeout_s, (int, float))
                                  or not 0 < timeout_s < float("inf")):
        raise ConfigError(f, "objective.timeout_s", f"expected a number of seconds > 0, got {timeout_s!r}")
    parameters = _get(raw, "parameters", dict, f, "", default=None)
    if parameters is not None:
        try:
            Space.from_dict(parameters)
        except SpaceError as exc:
            key = str(exc).split(":", 1)[0]
            raise ConfigError(f, f"parameters.{key}", str(exc).split(": ", 1)[-1]) from None

    opt = dict(_get(raw, "optimizer", dict, f, "", default={}))
    method = _get(opt, "method", str, f, "optimizer.", default="pso")
    if method not in OPTIMIZERS:
        raise ConfigError(f, "optimizer.method", f"unknown optimizer {method!r}; allowed: {sorted(OPTIMIZERS)}")
    population = _get(opt, "population", int, f, "optimizer.", default=None)
    generations = _get(opt, "generations", int, f, "optimizer.", default=None)
    for k, v in (("population", population), ("generations", generations)):
        if v is not None and v < 1:
            raise ConfigError(f, f"optimizer.{k}", f"must be >= 1, got {v}")
        if v is not None and v > MAX_COUNT:  # before anything is allocated for it
            raise ConfigError(f, f"optimizer.{k}", f"must be <= {MAX_COUNT:,}, got {v:,}")
    refine_raw = _get(opt, "refine", dict, f, "optimizer.", default={})
    bad = sorted(set(refine_raw) - {"stages", "shrink"})
    if bad:
        raise ConfigError(f, f"optimizer.refine.{bad[0]}", "unknown key; allowed: stages, shrink")
    stages = _get(refine_raw, "stages", int, f, "optimizer.refine.", default=1)
    shrink = float(_get(refine_raw, "shrink", (int, float), f, "optimizer.refine.", default=0.2))
    if stages < 1:
        raise ConfigError(f, "optimizer.refine.stages", f"must be >= 1, got {stages}")
    if not 0 < shrink < 1:
        raise ConfigError(f, "optimizer.refine.shrink", f"must be in (0, 1), got {shrink}")
    options = {k: v for k, v in opt.items() if k not in ("method", "population", "generations", "refine")}
    allowed = set(OPTIMIZERS[method].option_names()) - {"population", "generations"}
    for k in options:
        if k not in allowed:
            raise ConfigError(f, f"optimizer.{k}", f"unknown option for {method}; allowed: {sorted(allowed)}")
    if generations is None and not any(k in options for k in ("max_evals", "target", "patience")):
        generations = 30
    check_optimizer_options(f, method, optimizer_options(population, generations, options))
    optimizer = OptimizerConfig(method, population, generations, options, RefineConfig(stages, shrink))

    par = dict(_get(raw, "parallel", dict, f, "", default={}))
    bad = sorted(set(par) - {"backend", "n_jobs", "address", "connect_timeout_s"})
    if bad:
        raise ConfigError(f, f"parallel.{bad[0]}", "unknown key; allowed: backend, n_jobs, address, connect_timeout_s")
    backend = _get(par, "backend", str, f, "parallel.", default="loky")
    if backend not in ("serial", "loky", "dask", "threads"):
        raise ConfigError(f, "parallel.backend", f"unknown backend {backend!r}; allowed: serial, loky, dask, threads")
    n_jobs = _get(par, "n_jobs", int, f, "parallel.", default=2)
    if n_jobs < 1:
        raise ConfigError(f, "parallel.n_jobs", f"must be >= 1, got {n_jobs}")
    address = _get(par, "address", str, f, "parallel.", default=None)
    if address and backend != "dask":
        raise ConfigError(f, "parallel.address", f"only used with backend: dask (backend is {backend!r})")
    if address and not (_INPROC.fullmatch(address) or _ADDRESS.fullmatch(address)
                        and 0 < int(address.rsplit(":", 1)[1]) < 65536):
        raise ConfigError(f, "parallel.address", "expected a scheduler address such as tcp://10.0.0.5:8786 (tcp, "
                                                 f"tls, ucx, ws or wss; a host and a port 1-65535), got {address!r}")
    timeout = _get(par, "connect_timeout_s", (int, float), f, "parallel.", default=30.0)
    if "connect_timeout_s" in par and not address:
        raise ConfigError(f, "parallel.connect_timeout_s", "only used with parallel.address (a Dask scheduler)")
    if not 0 < timeout <= 3600:
        raise ConfigError(f, "parallel.connect_timeout_s", f"expected seconds in (0, 3600], got {timeout!r}")
    parallel = ParallelConfig(backend, n_jobs, address, float(timeout))
    output = str(_get(raw, "output", str, f, "", default="runs"))
    validation = parse_validation(raw.get("validation"), f)
    repeats = _get(raw, "repeats", int, f, "", default=1)
    if not 1 <= repeats <= MAX_REPEATS:
        raise ConfigError(f, "repeats", f"expected an integer in [1, {MAX_REPEATS}] (runs of this job, seeds seed + "
                                        f"0 .. seed + repeats - 1), got {repeats!r}")

    resolved = {
        "name": name,
        "description": raw.get("description", ""),
        "seed": seed,
        "objective": objective,
        "parameters": parameters,
        "optimizer": {"method": method, "population": population, "generations": generations, **options,
                      "refine": {"stages": stages, "shrink": shrink}},
        "parallel": {"backend": backend, "n_jobs": n_jobs, "address": address,
                     **({"connect_timeout_s": timeout} if "connect_timeout_s" in par else {})},
        "output": output,
    }
    if raw.get("validation") is not None:  # absent stays absent: the config hash of older jobs is unchanged
        resolved["validation"] = raw["validation"]
    if repeats > 1:  # one run is a job without the key: its config (and hash) is the plain run's
        resolved["repeats"] = repeats
    return RunConfig(name, seed, objective, parameters, optimizer, parallel, output, source,
                     base_dir or Path.cwd(), resolved, str(raw.get("description", "")), validation, repeats=repeats)
