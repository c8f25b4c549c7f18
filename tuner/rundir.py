"""The one owner of a run directory: its paths, the lock, atomic writes and the history append.

What the files hold (typed ``Meta``, ``Best``, ``Checkpoint``, ``HistoryRow``) and how a value is written
(``fmt_cell``, ``plain``, ``config_hash``) are :mod:`tuner.records`; :class:`RunDir` reads and writes them.

Layout of ``runs/<UTC time>-<name>-<6 hex>/``:

``config.yaml``       the resolved config, defaults filled in, as run
``.config.json``      the same config as canonical JSON (to name what changed if config.yaml is edited)
``meta.json``         status (running/finished/interrupted; failed: every evaluation failed), seed, config hash,
                      times, versions, git commit, host, CPU count, backend, evaluation counts, stop reason, notes
``history.csv``       one row per evaluation: eval, stage, generation, index, every parameter,
                      fitness, status, error, seconds, metrics (the record of truth)
``best.yaml``         best parameters, fitness, metrics and where they were found, derived from the
                      evaluations of ``history.csv`` (rewritten every generation, on resume and at the end)
``checkpoint.json``   how many rows of ``history.csv`` are complete generations (data only, no code)
``.lock``             holds an exclusive ``flock`` while a process runs or resumes the run
``report.md``, ``report.html``, ``figures/``  written when the run finishes
``validation.json``   with a ``validation:`` section or after ``tuner cv RUN_DIR``: the cross-validation
                      summary (tuning score, CV score, gap, large or not) and the final selection
``cv.md``, ``cv.csv`` the cross-validation tables (per fold, summary) of :mod:`tuner.cv`

A repeated run (``repeats: N``, :mod:`tuner.repeats`) holds no ``history.csv`` or ``checkpoint.json`` of its
own: ``config.yaml`` (with ``repeats``), ``meta.json`` (the counts and times summed over its repeats),
``repeats/seed-<s>/`` (one ordinary run directory per seed, as ``tuner run --seed s`` writes it),
``repeats.json`` (the spread over the repeats and which one was chosen, typed :class:`tuner.records.Repeats`)
and ``best.yaml`` (the chosen repeat's, its ``run`` naming it: ``repeats/seed-<s>``), then the report.

Nothing read from a run directory is ever unpickled or executed: a handed-over directory is data. Every file
is opened through :mod:`tuner.safe_io` (regular files only, no link of either kind where tuner writes, bounded
size); the code a config names is loaded only as :mod:`tuner.trust` allows.

Test hook: ``TUNER_FAULT_KILL_AT_WRITE=k`` (optionally ``k:after``) makes the process ``os._exit(137)``
at its k-th write through this module: by default just before the write takes effect (an atomic write
has its temporary file written but not renamed; a history append has written half of its bytes), with
``:after`` just after it. It exists for the fault-injection tests and does nothing when unset.
"""

from __future__ import annotations

import csv
import dataclasses
import errno
import io
import json
import os
from collections.abc import Iterator, Mapping
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import yaml

from tuner import digest, safe_yaml
from tuner.records import (
    FIXED_COLUMNS,
    RESULT_COLUMNS,
    Best,
    Checkpoint,
    HistoryRow,
    Meta,
    Repeats,
    RunError,
    config_hash,
    dump_yaml,
    first_difference,
    load_json,
    plain,
)
from tuner.safe_io import UnsafeFile, named, open_append, open_lock, read_text, refuse_links, regular, write_atomic

#: what this module owns; the records it reads and writes (``Meta``, ``Best``, ``Checkpoint``, ``HistoryRow``,
#: ``RunError`` and the encodings) are :mod:`tuner.records`'s, importable from here as well
__all__ = ["RunDir", "History", "atomic_write", "read_chain", "check_chain", "chain_secret", "chain_note", "CHAIN",
           "FAULT_ENV", "REPEATS_DIR", "RunError", "mark_stopped"]

FAULT_ENV = "TUNER_FAULT_KILL_AT_WRITE"
LEGACY_CHECKPOINT = "checkpoint.pkl"
#: the folder of a repeated run that holds its repeats' run directories
REPEATS_DIR = "repeats"

# --- writing -----------------------------------------------------------------------------------
_n_writes = 0


def _fault(phase: str) -> None:
    """The fault-injection hook (see the module docstring); ``phase`` is "before" or "after"."""
    spec = os.environ.get(FAULT_ENV)
    if not spec:
        return
    k, _, when = spec.partition(":")
    if _n_writes == int(k) and phase == (when or "before"):
        os._exit(137)


def atomic_write(path: Path, data: bytes | str) -> None:
    """Write to a temporary file, fsync, rename (:func:`tuner.safe_io.write_atomic`): readers see the old or the
    new file, never half; a link of either kind or a special file at ``path`` is refused."""
    global _n_writes
    _n_writes += 1
    write_atomic(path, data, before_replace=lambda: _fault("before"))
    _fault("after")


def _append(path: Path, text: str) -> None:
    """Append and fsync (a kill can leave a torn last line, which the checkpoint's row count excludes); a link
    of either kind or a special file at ``path`` is refused (:func:`tuner.safe_io.open_append`)."""
    global _n_writes
    _n_writes += 1
    with named(path), os.fdopen(open_append(path), "a", newline="") as fh:
        if os.environ.get(FAULT_ENV):
            fh.write(text[: len(text) // 2])
            fh.flush()
            os.fsync(fh.fileno())
            _fault("before")
            fh.write(text[len(text) // 2:])
        else:
            fh.write(text)
        fh.flush()
        os.fsync(fh.fileno())
    _fault("after")


# --- history -----------------------------------------------------------------------------------
class History:
    """Append-only ``history.csv``; the header grows (file rewritten) if new metric names appear. Beside it,
    ``history.chain``: each row's digest chained to the row before and to ``config_hash`` (:mod:`tuner.digest`),
    keyed when the user has set a chain key at the history's creation. A history without its chain is refused."""

    def __init__(self, path: Path, param_names: list[str], config_hash: str = ""):
        self.path = Path(path)
        self.chain_path = self.path.with_name(CHAIN)
        self.param_names = list(param_names)
        self.metric_names: list[str] = []
        self.config_hash, self._last = config_hash, config_hash
        if regular(self.path):
            try:
                header = next(csv.reader(io.StringIO(read_text(self.path), newline="")), None)
            except (UnicodeDecodeError, csv.Error) as exc:
                raise RunError(f"{self.path}: unreadable ({exc})") from None
            fixed = FIXED_COLUMNS + self.param_names + RESULT_COLUMNS
            if header is None or header[:len(fixed)] != fixed:
                raise RunError(f"{self.path}: header {header} does not start with the expected columns {fixed}")
            self.metric_names = header[len(fixed):]
            self.chain = read_chain(self.chain_path)  # RunError when missing, or keyed with a key not set here
            self.key = chain_secret(self.chain, self.chain_path)
            self._last = None  # read when first needed
        else:
            key = _user_key()
            self.chain, self.key = digest.Chain(key.id if key else None, []), key.secret if key else None
            atomic_write(self.chain_path, self.chain.text())  # first: a kill between the two leaves no history
            self._rewrite([])                                 # without its chain

    @property
    def columns(self) -> list[str]:
        return FIXED_COLUMNS + self.param_names + RESULT_COLUMNS + self.metric_names

    def _rewrite(self, rows: list[dict[str, Any]]) -> None:
        buf = io.StringIO()
        w = csv.DictWriter(buf, fieldnames=self.columns, extrasaction="ignore", lineterminator="\n")
        w.writeheader()
        for r in rows:
            w.writerow(r)
        atomic_write(self.path, buf.getvalue())

    def read_rows(self) -> list[dict[str, str]]:
        try:
            return list(csv.DictReader(io.StringIO(read_text(self.path), newline="")))
        except (UnicodeDecodeError, csv.Error) as exc:
            raise RunError(f"{self.path}: unreadable ({exc})") from None

    def truncate(self, n_rows: int) -> list[dict[str, str]]:
        """Keep the first ``n_rows`` evaluations (what the checkpoint covers), checked, and return them."""
        rows = self.read_rows()
        if len(rows) < n_rows:
            raise RunError(f"{self.path}: {len(rows)} rows, but checkpoint.json says {n_rows} were written")
        digests = read_chain(self.chain_path).digests
        check_chain(self.path, rows[:n_rows], digests, self.config_hash, self.key)
        if len(digests) != n_rows:
            atomic_write(self.chain_path, self.chain.text(digests[:n_rows]))
        self._last = digests[n_rows - 1][1] if n_rows else self.config_hash
        if len(rows) != n_rows:
            self._rewrite(rows[:n_rows])
        return rows[:n_rows]

    def append(self, records: list[HistoryRow]) -> None:
        """Append ``records`` (and their digests to ``history.chain``); a metric not in the header yet adds a
        column (the file is rewritten with it)."""
        rows = [r.cells() for r in records]
        new = sorted({k for r in rows for k in r} - set(self.columns))
        if new:
            old = self.read_rows()
            self.metric_names += new
            self._rewrite(old)
        if self._last is None:
            digests = read_chain(self.chain_path).digests
            self._last = digests[-1][1] if digests else self.config_hash
        buf, lines = io.StringIO(), []
        w = csv.DictWriter(buf, fieldnames=self.columns, extrasaction="ignore", lineterminator="\n")
        for r in rows:
            w.writerow(r)
            self._last = digest.row_digest(str(self._last), r, self.key)
            lines.append(f"{r.get('eval')},{self._last}\n")
        _append(self.path, buf.getvalue())
        if lines:
            _append(self.chain_path, "".join(lines))


CHAIN = digest.CHAIN


def _user_key() -> digest.ChainKey | None:
    try:
        return digest.chain_key()
    except digest.ChainKeyError as exc:
        raise RunError(str(exc)) from None


def read_chain(path: Path) -> digest.Chain:
    """``history.chain`` parsed; :class:`RunError` when it is missing (a history is never used without it)."""
    if not regular(path):
        raise RunError(f"{path}: missing beside history.csv; without it the history cannot be checked for edits, "
                       "so it is not used (restore it from where the run came from, or start the run again)")
    try:
        return digest.parse_chain(read_text(path))
    except UnicodeDecodeError as exc:
        raise RunError(f"{path}: unreadable ({exc})") from None


def chain_secret(chain: digest.Chain, where: Path) -> bytes | None:
    """The key ``chain`` is keyed with (None: unkeyed); :class:`RunError` when the user's key is missing or another."""
    try:
        return digest.key_for(chain, where)
    except digest.ChainKeyError as exc:
        raise RunError(str(exc)) from None


def chain_note(chain: digest.Chain) -> str:
    """A note for an unkeyed chain read while the user has a chain key set (anyone could have recomputed it)."""
    if chain.key_id is None and _user_key() is not None:
        return ("history.chain is not keyed (written without a chain key): it shows no naive edit, but anyone "
                "could have recomputed it after editing the history")
    return ""


def check_chain(path: Path, rows: list[dict[str, str]], digests: list[tuple[str, str]], config_hash: str,
                key: bytes | None = None) -> None:
    """:class:`RunError` naming the first of ``rows`` that does not match ``history.chain`` (:mod:`tuner.digest`)."""
    if (bad := digest.first_mismatch(rows, digests, config_hash, key)) is not None:
        raise RunError(f"{path}: row eval={bad[0]}: {bad[1]}: the history was edited (or rows removed or "
                       "reordered), so it is not used")


# --- the directory -----------------------------------------------------------------------------
class RunDir:
    """Every read and write of one run directory goes through here."""

    def __init__(self, path: str | Path):
        self.path = Path(path)
        refuse_links(self.path)  # a handed-over directory is data: no entry of it is followed (tuner.safe_io)

    def __repr__(self) -> str:
        return f"RunDir({str(self.path)!r})"

    def file(self, name: str) -> Path:
        return self.path / name

    # --- reading ------------------------------------------------------------------------------
    def _text(self, name: str, what: str) -> str:
        p = self.path / name
        if not self.path.is_dir():
            raise RunError(f"{self.path}: not a run directory (no such directory)")
        if not regular(p):  # a link, a FIFO or a device is an error naming it (tuner.safe_io), never followed
            raise RunError(f"{p}: missing ({what})")
        try:
            return read_text(p)
        except UnsafeFile:
            raise
        except (OSError, UnicodeDecodeError) as exc:
            raise RunError(f"{p}: unreadable: {exc}") from None

    def _json(self, name: str, what: str) -> Any:
        try:
            return load_json(self._text(name, what))
        except ValueError as exc:
            raise RunError(f"{self.path / name}: not valid JSON: {exc}") from None

    def _yaml(self, name: str, what: str) -> Any:
        try:
            return safe_yaml.load(self._text(name, what))
        except yaml.YAMLError as exc:
            msg = safe_yaml.one_line(exc)
            raise RunError(f"{self.path / name}: not valid YAML: {msg}") from None

    def is_run(self) -> bool:
        return regular(self.path / "meta.json")

    def meta(self) -> Meta:
        return Meta.from_dict(self._json("meta.json", "not a run directory, or killed before it started"),
                              self.path / "meta.json")

    def config(self) -> dict[str, Any]:
        """The resolved config as written at creation (a mapping)."""
        doc = self._yaml("config.yaml", "the run's resolved config")
        if not isinstance(doc, dict):
            raise RunError(f"{self.path / 'config.yaml'}: expected a mapping, got {type(doc).__name__}")
        return doc

    def config_snapshot(self) -> dict[str, Any] | None:
        p = self.path / ".config.json"
        try:
            return load_json(read_text(p)) if regular(p) else None
        except (OSError, ValueError):
            return None

    def has_best(self) -> bool:
        return regular(self.path / "best.yaml")

    def best(self) -> Best:
        return Best.from_doc(self._yaml("best.yaml", "nothing evaluated yet?"), self.path / "best.yaml")

    def checkpoint(self) -> Checkpoint | None:
        """The checkpoint, ``None`` if the run never completed a generation; a legacy pickle is refused."""
        if os.path.lexists(self.path / LEGACY_CHECKPOINT):
            raise RunError(f"{self.path / LEGACY_CHECKPOINT}: a pickled checkpoint from an older tuner; pickles "
                           "can run arbitrary code, so it is never loaded and this run cannot be resumed "
                           "(its history.csv and best.yaml stay readable; start the job again)")
        if not regular(self.path / "checkpoint.json"):
            return None
        return Checkpoint.from_doc(self._json("checkpoint.json", "checkpoint"), self.path / "checkpoint.json")

    def repeat_count(self) -> int:
        """``repeats`` of the run's config: N > 1 for a repeated run, 1 for a single run (or no config)."""
        if not regular(self.path / "config.yaml"):
            return 1
        n = self.config().get("repeats", 1)
        return n if isinstance(n, int) and not isinstance(n, bool) and n > 1 else 1

    def repeat_name(self, seed: int) -> str:
        """The repeat of ``seed``'s directory, relative to this one (``repeats/seed-<s>``)."""
        return f"{REPEATS_DIR}/seed-{int(seed)}"

    def repeats(self) -> Repeats | None:
        """``repeats.json`` of a repeated run (None before its first repeat ended, or for a single run)."""
        if not regular(self.path / "repeats.json"):
            return None
        return Repeats.from_doc(self._json("repeats.json", "the spread over the repeats"), self.path / "repeats.json")

    def chosen_repeat(self) -> Path | None:
        """A repeated run's chosen repeat's directory (None before one is chosen, or for a single run)."""
        rep = self.repeats()
        return None if rep is None or rep.chosen_entry is None else self.path / rep.chosen_entry.run

    def history(self, param_names: list[str], config_hash: str = "") -> History:
        return History(self.path / "history.csv", param_names, config_hash)

    def history_rows(self) -> list[dict[str, str]]:
        """The rows of ``history.csv`` as strings (empty when nothing was evaluated yet)."""
        p = self.path / "history.csv"
        if not regular(p):
            return []
        try:
            return list(csv.DictReader(io.StringIO(read_text(p), newline="")))
        except UnsafeFile:
            raise
        except (OSError, UnicodeDecodeError, csv.Error) as exc:
            raise RunError(f"{p}: unreadable ({exc})") from None

    # --- writing ------------------------------------------------------------------------------
    def write_config(self, resolved: dict[str, Any]) -> str:
        """Write ``config.yaml`` and its canonical snapshot; return the config hash."""
        atomic_write(self.path / "config.yaml", dump_yaml(resolved))
        atomic_write(self.path / ".config.json", json.dumps(plain(resolved), sort_keys=True, default=str))
        return config_hash(resolved)

    def write_meta(self, meta: Meta) -> None:
        atomic_write(self.path / "meta.json", json.dumps(meta.to_dict(), indent=1))

    def write_best(self, best: Best) -> None:
        atomic_write(self.path / "best.yaml", dump_yaml(best.to_doc()))

    def write_repeats(self, rep: Repeats) -> None:
        atomic_write(self.path / "repeats.json", json.dumps(rep.to_doc(), indent=1))

    def write_checkpoint(self, ck: Checkpoint) -> None:
        atomic_write(self.path / "checkpoint.json", json.dumps(dataclasses.asdict(ck)))

    def validation(self) -> dict[str, Any] | None:
        """``validation.json`` (``None`` when the run has none)."""
        if not regular(self.path / "validation.json"):
            return None
        doc = self._json("validation.json", "validation results")
        if not isinstance(doc, dict):
            raise RunError(f"{self.path / 'validation.json'}: expected a JSON object, got {type(doc).__name__}")
        return doc

    def write_validation(self, doc: dict[str, Any]) -> None:
        atomic_write(self.path / "validation.json", json.dumps(plain(doc), indent=1))

    def fingerprint(self) -> dict[str, Any] | None:
        """``fingerprint.json``, the tuning data's statistics (``None`` when the run has none)."""
        if not (self.path / "fingerprint.json").is_file():
            return None
        doc = self._json("fingerprint.json", "data fingerprint")
        return doc if isinstance(doc, dict) else None

    def write_fingerprint(self, doc: Mapping[str, Any]) -> None:
        atomic_write(self.path / "fingerprint.json", json.dumps(plain(dict(doc)), indent=1))

    def write_cv_tables(self, markdown: str, table_csv: str) -> None:
        """``cv.md`` and ``cv.csv`` (the texts of :func:`tuner.cv.cv_texts`)."""
        atomic_write(self.path / "cv.csv", table_csv)
        atomic_write(self.path / "cv.md", markdown)

    def remove_tmp(self) -> list[str]:
        """Delete temporary files a killed writer left behind; return their names."""
        gone = []
        for p in self.path.glob(".*.tmp*"):
            p.unlink(missing_ok=True)  # unlink removes a link itself, never its target
            gone.append(p.name)
        return gone

    def check_config(self, meta: Meta) -> dict[str, Any]:
        """The config, refused if it changed since the run was created (hash in meta.json)."""
        doc = self.config()
        if meta.config_hash and config_hash(doc) != meta.config_hash:
            snap = self.config_snapshot()
            where = first_difference(snap, json.loads(json.dumps(plain(doc), default=str))) if snap else ""
            what = f"first difference at `{where}`" if where else "hash differs from meta.json"
            raise RunError(f"{self.path / 'config.yaml'}: changed since the run started ({what}); a run resumes "
                           "only with the config it started with: restore it, or start a new run")
        return doc

    @contextmanager
    def lock(self) -> Iterator[None]:
        """Hold an exclusive ``flock`` on ``.lock`` (released when the process ends, however it ends)."""
        import fcntl

        self.path.mkdir(parents=True, exist_ok=True)
        fd = open_lock(self.path / ".lock")  # never truncate a link's target (either kind), never block on a FIFO
        try:
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except OSError as exc:
                if exc.errno not in (errno.EWOULDBLOCK, errno.EAGAIN, errno.EACCES):
                    raise
                pid = os.pread(fd, 32, 0).decode(errors="replace").strip() or "?"
                raise RunError(f"{self.path}: in use by pid {pid}") from None
            os.ftruncate(fd, 0)
            os.pwrite(fd, f"{os.getpid()}\n".encode(), 0)
            yield
        finally:
            os.close(fd)


def mark_stopped(run_dirs: list[str], wait_s: float = 5.0) -> None:
    """Runs whose process was stopped from outside (a parallel sweep's workers, stopped with the pool): each
    whose ``meta.json`` still says ``running`` once no process holds its lock (waiting up to ``wait_s``) is
    marked ``interrupted``, as a run does when it is stopped itself; ``tuner sweep`` or ``tuner resume``
    continues it."""
    import datetime
    import time

    left, deadline = list(run_dirs), time.monotonic() + wait_s
    while left:
        busy = []
        for d in left:
            try:
                rd = RunDir(d)
                if not rd.is_run() or rd.meta().status != "running":
                    continue
                with rd.lock():  # a RunError while a worker still holds it
                    meta = rd.meta()
                    if meta.status == "running":
                        now = datetime.datetime.now(datetime.UTC).strftime("%Y-%m-%dT%H:%M:%SZ")
                        rd.write_meta(meta.replace(status="interrupted", interrupted=now))
            except RunError as exc:
                if "in use by pid" in str(exc):
                    busy.append(d)
            except (OSError, ValueError):
                pass
        if not busy or time.monotonic() > deadline:
            return
        left = busy
        time.sleep(0.1)
