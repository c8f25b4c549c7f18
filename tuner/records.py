"""The records of a run directory: what its files hold, typed, and how each value is written.

- :class:`Meta` (``meta.json``), :class:`Best` (``best.yaml``), :class:`Checkpoint` (``checkpoint.json``),
  :class:`HistoryRow` (one row of ``history.csv``: one evaluation) and :class:`Repeats` (``repeats.json`` of a
  repeated run: its :class:`RepeatEntry` per seed and the :class:`Spread` over them), each read back with the
  file and key named when malformed (:class:`RunError`);
- the encodings: :func:`fmt_cell` / :func:`parse_cell` (a value in ``history.csv``, floats as ``repr`` so they
  read back exactly), :func:`plain` (numpy values and paths as YAML/JSON-native data), :func:`dump_yaml`,
  :func:`config_hash` and :func:`first_difference` (a resolved config's identity, and where two differ).

Nothing here touches a file: :class:`tuner.rundir.RunDir` owns the directory (paths, the lock, atomic writes,
the history append) and reads and writes these records.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from tuner.loop import BestPoint

__all__ = ["RunError", "Meta", "Timing", "Best", "Checkpoint", "HistoryRow", "Spread", "RepeatEntry", "Repeats",
           "STATUSES", "FIXED_COLUMNS", "RESULT_COLUMNS", "ERROR_LIMIT", "plain", "dump_yaml", "fmt_cell", "parse_cell",
           "cell", "read_back", "clip_error", "config_hash", "first_difference", "load_json"]

#: ``meta.json``'s status values
STATUSES = ("created", "running", "finished", "interrupted", "failed")
#: the first columns of ``history.csv``; then one per parameter, then :data:`RESULT_COLUMNS`, then the metrics
FIXED_COLUMNS = ["eval", "stage", "generation", "index"]
RESULT_COLUMNS = ["fitness", "status", "error", "seconds"]
#: the longest error text a row keeps (a 128 kB message would exceed the CSV reader's field limit)
ERROR_LIMIT = 4000


class RunError(RuntimeError):
    """A run directory that cannot be used as asked (missing, finished, corrupt, in use)."""



# --- encodings -----------------------------------------------------------------------------------
def plain(v: Any) -> Any:
    """Numpy scalars/arrays, tuples and paths turned into YAML/JSON-native values."""
    if isinstance(v, dict):
        return {str(k): plain(x) for k, x in v.items()}
    if isinstance(v, (list, tuple)):
        return [plain(x) for x in v]
    if isinstance(v, np.generic):
        return v.item()
    if isinstance(v, np.ndarray):
        return v.tolist()
    if isinstance(v, Path):
        return str(v)
    return v


def dump_yaml(d: Any) -> str:
    return yaml.safe_dump(plain(d), sort_keys=False, default_flow_style=False, width=100)


def fmt_cell(v: Any) -> Any:
    """How a value is written into ``history.csv`` (floats as ``repr``, so they read back exactly)."""
    if isinstance(v, (bool, np.bool_)):
        return str(bool(v))
    if isinstance(v, (float, np.floating)):
        return repr(float(v))
    if isinstance(v, (list, tuple, dict)):
        return json.dumps(plain(v))
    return v


def parse_cell(s: str) -> Any:
    """Inverse of :func:`fmt_cell` for metric cells: int, float, JSON list/dict, else the string."""
    for conv in (int, float):
        try:
            return conv(s)
        except ValueError:
            pass
    if s[:1] in "[{":
        try:
            return load_json(s)
        except ValueError:
            pass
    return s


def load_json(text: str | bytes) -> Any:
    """``json.loads`` of text read from a run or sweep directory: malformed or too deeply nested text (the
    parser's recursion ends in ``RecursionError``) is a ``ValueError`` (``json.JSONDecodeError`` is one)."""
    try:
        doc = json.loads(text)
    except RecursionError:
        doc = None
    else:
        if _depth(doc) <= MAX_JSON_DEPTH:
            return doc
    raise ValueError(f"nested deeper than {MAX_JSON_DEPTH} levels; refused (tuner never writes such a document)")


#: the deepest JSON document read from a run or sweep directory (the YAML limit, :data:`tuner.safe_yaml.MAX_DEPTH`)
MAX_JSON_DEPTH = 64


def _depth(doc: Any) -> int:
    """Nesting depth of a parsed JSON document (iterative: a deep one must not overflow the stack here)."""
    deepest, todo = 0, [(doc, 1)]
    while todo:
        v, d = todo.pop()
        if isinstance(v, (dict, list)):
            deepest = max(deepest, d)
            if d > MAX_JSON_DEPTH:
                return d
            todo.extend((x, d + 1) for x in (v.values() if isinstance(v, dict) else v))
    return deepest


def config_hash(doc: Any) -> str:
    """sha256 of the canonical JSON of a resolved config."""
    return hashlib.sha256(json.dumps(plain(doc), sort_keys=True, default=str).encode()).hexdigest()


def first_difference(a: Any, b: Any, prefix: str = "") -> str:
    """The first dotted key where two config documents differ ('' when they are equal)."""
    if isinstance(a, dict) and isinstance(b, dict):
        for k in sorted(set(a) | set(b), key=str):
            if k not in a or k not in b:
                return f"{prefix}{k}"
            d = first_difference(a[k], b[k], f"{prefix}{k}.")
            if d:
                return d
        return ""
    return "" if a == b else prefix.rstrip(".") or "(top level)"



def cell(v: Any) -> str:
    """The text of ``v`` in ``history.csv`` (empty for None)."""
    return "" if v is None else str(fmt_cell(v))


def read_back(metrics: Mapping[str, Any]) -> dict[str, Any]:
    """``metrics`` as they read back from ``history.csv`` (so a replayed best equals the live one)."""
    return {str(k): parse_cell(c) for k, v in metrics.items() if (c := cell(v)) != ""}


# --- typed records -----------------------------------------------------------------------------
def _versioned(doc: Any, version: int, where: Path) -> dict[str, Any]:
    """``doc`` checked to be a JSON object of the record's ``version``."""
    if not isinstance(doc, dict):
        raise RunError(f"{where}: expected a JSON object, got {type(doc).__name__}")
    if doc.get("version") != version:
        raise RunError(f"{where}: version: expected {version}, got {doc.get('version')!r}")
    return doc


def _req(doc: dict[str, Any], key: str, types: type | tuple[type, ...], where: Path) -> Any:
    if key not in doc:
        raise RunError(f"{where}: {key}: missing")
    v = doc[key]
    allowed = types if isinstance(types, tuple) else (types,)
    if not isinstance(v, allowed) or (isinstance(v, bool) and bool not in allowed):  # True is not a count
        raise RunError(f"{where}: {key}: expected {getattr(types, '__name__', types)}, got {v!r}")
    return v


@dataclass(frozen=True)
class Timing:
    """Wall time of all sessions, summed objective time, number of sessions (run + resumes)."""

    wall_s: float = 0.0
    objective_s: float = 0.0
    sessions: int = 0


@dataclass(frozen=True)
class Meta:
    """``meta.json``: what ran, where, how far it got. Unknown keys are kept in ``extra``."""

    status: str
    name: str
    seed: int
    created: str
    config_source: str = ""
    config_hash: str = ""
    versions: dict[str, str] = field(default_factory=dict)
    git_commit: str = ""
    host: str = ""
    cpu_count: int | None = None
    backend: str = "serial"
    n_jobs: int = 1
    n_jobs_requested: int | None = None
    backend_detail: str = ""
    optimizer: str = ""
    n_evals: int = 0
    n_failed: int = 0
    generations: int = 0
    stop_reason: str = ""
    timing: Timing = field(default_factory=Timing)
    started: str = ""
    finished: str = ""
    interrupted: str = ""
    notes: tuple[str, ...] = ()
    extra: dict[str, Any] = field(default_factory=dict)

    def replace(self, **kw: Any) -> Meta:
        return dataclasses.replace(self, **kw)

    def to_dict(self) -> dict[str, Any]:
        d = {f.name: getattr(self, f.name) for f in dataclasses.fields(self) if f.name != "extra"}
        d["timing"] = dataclasses.asdict(self.timing)
        d["notes"] = list(self.notes)
        return {**self.extra, **plain(d)}

    @classmethod
    def from_dict(cls, doc: Any, where: Path) -> Meta:
        if not isinstance(doc, dict):
            raise RunError(f"{where}: expected a JSON object, got {type(doc).__name__}")
        status = _req(doc, "status", str, where)
        if status not in STATUSES:
            raise RunError(f"{where}: status: expected one of {list(STATUSES)}, got {status!r}")
        _req(doc, "name", str, where)
        _req(doc, "seed", int, where)
        for key in ("n_evals", "n_failed", "generations"):
            if key in doc:
                _req(doc, key, int, where)
        t = doc.get("timing") or {}
        if not isinstance(t, dict):
            raise RunError(f"{where}: timing: expected an object, got {t!r}")
        try:
            timing = Timing(float(t.get("wall_s", 0.0)), float(t.get("objective_s", 0.0)), int(t.get("sessions", 0)))
        except (TypeError, ValueError) as exc:
            raise RunError(f"{where}: timing: {exc}") from None
        names = {f.name for f in dataclasses.fields(cls)}
        kw = {k: v for k, v in doc.items() if k in names and k not in ("timing", "extra", "notes")}
        kw.setdefault("created", "")
        return cls(**kw, timing=timing, notes=tuple(doc.get("notes") or ()),
                   extra={k: v for k, v in doc.items() if k not in names})


@dataclass(frozen=True)
class Best(BestPoint):
    """``best.yaml``: the best successful evaluation of the history (a :class:`tuner.loop.BestPoint`),
    the run it belongs to, the objective's held-out scores after the run (``evaluation``) and the
    complete configuration of the tuned system (``deployment``: a :class:`tuner.deployment.Deployment`
    as plain data; ``params`` stays the run's point as the history records it)."""

    run: str = ""
    evaluation: dict[str, Any] = field(default_factory=dict)
    deployment: dict[str, Any] = field(default_factory=dict)

    def to_doc(self) -> dict[str, Any]:
        doc = {"params": self.params, "fitness": self.fitness, "metrics": self.metrics,
               "found": {"stage": self.stage, "generation": self.generation, "eval": self.eval}, "run": self.run}
        if self.evaluation:
            doc["evaluation"] = self.evaluation
        if self.deployment:
            doc["deployment"] = self.deployment
        return plain(doc)

    @classmethod
    def from_doc(cls, doc: Any, where: Path) -> Best:
        if not isinstance(doc, dict):
            raise RunError(f"{where}: expected a mapping, got {type(doc).__name__}")
        params = _req(doc, "params", dict, where)
        fitness = _req(doc, "fitness", (int, float), where)
        found = doc.get("found") or {}
        if not isinstance(found, dict):
            raise RunError(f"{where}: found: expected a mapping, got {found!r}")
        deployment = doc.get("deployment") or {}
        if not isinstance(deployment, dict):
            raise RunError(f"{where}: deployment: expected a mapping, got {deployment!r}")
        return cls(dict(params), float(fitness), dict(doc.get("metrics") or {}), int(found.get("stage", 0)),
                   int(found.get("generation", -1)), int(found.get("eval", -1)), str(doc.get("run", "")),
                   dict(doc.get("evaluation") or {}), dict(deployment))


@dataclass(frozen=True)
class Checkpoint:
    """``checkpoint.json``: the first ``n_evals`` rows of ``history.csv`` are complete generations.

    Resuming recreates the optimiser from the run seed and replays ``tell`` with the recorded fitness
    of those rows: the optimiser state (pycma's included) is rebuilt exactly, no object is stored, and
    a history edited by hand is detected (the replayed optimiser asks other points than recorded).
    """

    n_evals: int
    stage: int
    generations: int
    version: int = 2

    @classmethod
    def from_doc(cls, doc: Any, where: Path) -> Checkpoint:
        doc = _versioned(doc, 2, where)
        vals = [_req(doc, k, int, where) for k in ("n_evals", "stage", "generations")]
        if min(vals) < 0:
            raise RunError(f"{where}: negative counts {vals}")
        return cls(*vals)



def clip_error(text: str, limit: int = ERROR_LIMIT) -> str:
    """An error text as a row stores it: one line, at most ``limit`` characters, its length noted when cut."""
    text = text.replace("\n", " ")
    if len(text) <= limit:
        return text
    return f"{text[:limit]} [... {len(text):,} characters, cut to {limit:,}]"


@dataclass(frozen=True)
class HistoryRow:
    """One row of ``history.csv``: one evaluation, where the run asked for it and what it gave.

    :meth:`cells` is the row as written (:func:`fmt_cell` for every value, so floats read back exactly);
    :meth:`parse` reads a row of strings back (the metrics through :func:`parse_cell`).
    """

    eval: int
    stage: int
    generation: int
    index: int
    params: dict[str, Any]
    fitness: float
    status: str
    error: str = ""
    seconds: float = 0.0
    metrics: dict[str, Any] = field(default_factory=dict)

    def cells(self) -> dict[str, Any]:
        """``{column: value}`` as :class:`tuner.rundir.History` appends it."""
        row: dict[str, Any] = {"eval": self.eval, "stage": self.stage, "generation": self.generation,
                               "index": self.index}
        row.update({k: fmt_cell(v) for k, v in self.params.items()})
        row.update(fitness=fmt_cell(float(self.fitness)), status=self.status, error=clip_error(self.error),
                   seconds=f"{self.seconds:.6f}")
        row.update({k: fmt_cell(v) for k, v in self.metrics.items()})
        return row

    @classmethod
    def parse(cls, row: Mapping[str, Any], names: list[str], where: Path) -> HistoryRow:
        """A row of ``csv.DictReader`` strings over parameters ``names``; :class:`RunError` naming the row when
        its status is not ``ok``/``failed`` or its counters, fitness or seconds are not numbers."""
        at = f"{where}: row eval={row.get('eval')}"
        if row.get("status") not in ("ok", "failed"):
            raise RunError(f"{at}: status {row.get('status')!r}")
        try:
            counters = [int(row[k]) for k in FIXED_COLUMNS]
        except (KeyError, TypeError, ValueError):
            raise RunError(f"{at}: {'/'.join(FIXED_COLUMNS)} not integers") from None
        try:
            fit, secs = float(row["fitness"]), float(row["seconds"])
        except (KeyError, TypeError, ValueError):
            raise RunError(f"{at}: fitness/seconds not numbers") from None
        skip = {*FIXED_COLUMNS, *RESULT_COLUMNS, *names}
        params = {n: parse_cell(row[n]) for n in names}
        metrics = {k: parse_cell(v) for k, v in row.items()
                   if isinstance(k, str) and k not in skip and isinstance(v, str) and v != ""}
        return cls(*counters, params, fit, row["status"], row.get("error") or "", secs, metrics)


# --- repeats.json ------------------------------------------------------------------------------
def _num_or_none(v: Any, where: Path, key: str) -> float | None:
    if v is None:
        return None
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        raise RunError(f"{where}: {key}: expected a number or null, got {v!r}")
    return float(v)


@dataclass(frozen=True)
class Spread:
    """A quantity over the repeats that have it: median, lowest, highest and how many (``n``); for a searched
    parameter also ``range_share``, ``high - low`` as a share of its search range (log10 for log ones)."""

    median: float
    low: float
    high: float
    n: int
    range_share: float | None = None

    @property
    def width(self) -> float:
        """``high - low``: the spread over seeds."""
        return self.high - self.low

    @classmethod
    def from_doc(cls, doc: Any, where: Path, key: str) -> Spread | None:
        if doc is None:
            return None
        if not isinstance(doc, dict):
            raise RunError(f"{where}: {key}: expected a mapping, got {doc!r}")
        vals = [_num_or_none(doc.get(k), where, f"{key}.{k}") for k in ("median", "low", "high")]
        if any(v is None for v in vals):
            raise RunError(f"{where}: {key}: median, low and high are required")
        n = _req(doc, "n", int, where)
        return cls(*vals, n, _num_or_none(doc.get("range_share"), where, f"{key}.range_share"))  # type: ignore[arg-type]


@dataclass(frozen=True)
class RepeatEntry:
    """One repeat of a repeated run: its seed, its run directory (relative to the parent), how far it got and,
    once it has a best, its best fitness, searched values, held-out score (``held_out_key`` says which:
    :func:`tuner.spread.held_out_score`) and the defaults' fitness."""

    index: int
    seed: int
    run: str
    status: str
    n_evals: int = 0
    n_failed: int = 0
    fitness: float | None = None
    params: dict[str, Any] = field(default_factory=dict)
    held_out: float | None = None
    held_out_key: str = ""
    defaults_fitness: float | None = None
    wall_s: float = 0.0

    @classmethod
    def from_doc(cls, doc: Any, where: Path) -> RepeatEntry:
        if not isinstance(doc, dict):
            raise RunError(f"{where}: repeats: expected mappings, got {doc!r}")
        idx, seed = _req(doc, "index", int, where), _req(doc, "seed", int, where)
        at = f"repeats[{idx}]"
        run, status = _req(doc, "run", str, where), _req(doc, "status", str, where)
        if run.startswith("/") or ".." in Path(run).parts:
            raise RunError(f"{where}: {at}.run: expected a path inside the run directory, got {run!r}")
        params = doc.get("params") or {}
        if not isinstance(params, dict):
            raise RunError(f"{where}: {at}.params: expected a mapping, got {params!r}")
        return cls(idx, seed, run, status, int(doc.get("n_evals") or 0), int(doc.get("n_failed") or 0),
                   _num_or_none(doc.get("fitness"), where, f"{at}.fitness"), dict(params),
                   _num_or_none(doc.get("held_out"), where, f"{at}.held_out"), str(doc.get("held_out_key") or ""),
                   _num_or_none(doc.get("defaults_fitness"), where, f"{at}.defaults_fitness"),
                   float(doc.get("wall_s") or 0.0))


@dataclass(frozen=True)
class Repeats:
    """``repeats.json`` of a repeated run (``repeats: N``; computed by :func:`tuner.spread.summarize`).

    Attributes
    ----------
    seeds : tuple of int
        The repeats' seeds (:data:`tuner.spread.SEED_RULE`).
    entries : tuple of RepeatEntry
        One per repeat, in seed order.
    complete : bool
        Every repeat finished (False while the run goes on or after an interruption).
    fitness : Spread or None
        The best fitness over the repeats with a best.
    params : dict
        ``{name: Spread}`` of each searched parameter's best value.
    held_out_key : str
        ``test_fitness`` (the job's test data), ``selection`` (the held-out fold of ``validation.select``) or
        ``""`` when the repeats have no held-out score.
    held_out : Spread or None
        That score over the repeats.
    chosen : int or None
        Index of the repeat whose best is the run's ``best.yaml`` (None until one is chosen).
    chosen_by : str
        ``held_out`` or ``median_fitness``; ``rule`` says it in words.
    defaults_fitness, gain : float or None
        The defaults' fitness (median over the repeats) and the gain of tuning, defaults minus the median
        best fitness.
    warning, warn_rule : str
        The spread warning (empty when there is none) and its rule in words.
    """

    seeds: tuple[int, ...]
    entries: tuple[RepeatEntry, ...]
    complete: bool = False
    fitness: Spread | None = None
    params: dict[str, Spread] = field(default_factory=dict)
    held_out_key: str = ""
    held_out: Spread | None = None
    chosen: int | None = None
    chosen_by: str = ""
    rule: str = ""
    defaults_fitness: float | None = None
    gain: float | None = None
    warning: str = ""
    warn_rule: str = ""
    version: int = 1

    @property
    def n(self) -> int:
        return len(self.seeds)

    @property
    def chosen_entry(self) -> RepeatEntry | None:
        return None if self.chosen is None else self.entries[self.chosen]

    def to_doc(self) -> dict[str, Any]:
        doc = dataclasses.asdict(self)
        doc["seeds"] = list(self.seeds)
        return plain(doc)

    @classmethod
    def from_doc(cls, doc: Any, where: Path) -> Repeats:
        doc = _versioned(doc, 1, where)
        seeds = _req(doc, "seeds", list, where)
        if not all(isinstance(s, int) and not isinstance(s, bool) for s in seeds):
            raise RunError(f"{where}: seeds: expected integers, got {seeds!r}")
        entries = tuple(RepeatEntry.from_doc(e, where) for e in _req(doc, "entries", list, where))
        params = doc.get("params") or {}
        if not isinstance(params, dict):
            raise RunError(f"{where}: params: expected a mapping, got {params!r}")
        chosen = doc.get("chosen")
        if chosen is not None and (not isinstance(chosen, int) or not 0 <= chosen < len(entries)):
            raise RunError(f"{where}: chosen: expected a repeat index in [0, {len(entries)}), got {chosen!r}")
        fitness = Spread.from_doc(doc.get("fitness"), where, "fitness")
        spreads = {str(k): Spread.from_doc(v, where, f"params.{k}") for k, v in params.items()}
        return cls(tuple(seeds), entries, bool(doc.get("complete")), fitness,
                   {k: s for k, s in spreads.items() if s is not None},
                   str(doc.get("held_out_key") or ""), Spread.from_doc(doc.get("held_out"), where, "held_out"), chosen,
                   str(doc.get("chosen_by") or ""), str(doc.get("rule") or ""),
                   _num_or_none(doc.get("defaults_fitness"), where, "defaults_fitness"),
                   _num_or_none(doc.get("gain"), where, "gain"), str(doc.get("warning") or ""),
                   str(doc.get("warn_rule") or ""))
