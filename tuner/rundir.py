"""The one owner of a run directory: its paths, the lock, atomic writes and the history append.

What the files hold (typed ``Meta``, ``Best``, ``Checkpoint``, ``HistoryRow``) and how a value is written
(``fmt_cell``, ``plain``, ``config_hash``) are :mod:`tuner.records`; :class:`RunDir` reads and writes them.

Layout of ``runs/<UTC time>-<name>-<6 hex>/``:

``config.yaml``       the resolved config, defaults filled in, as run
``.config.json``      the same config as canonical JSON (to name what changed if config.yaml is edited)
``meta.json``         status (running/finished/interrupted/failed), seed, config hash, times, versions,
                      git commit, host, CPU count, backend, evaluation counts, stop reason, notes
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

Nothing read from a run directory is ever unpickled or executed: a handed-over directory is data.
(A config with ``objective.kind: python`` imports the module it names by design: trust the config.)

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
    RunError,
    config_hash,
    dump_yaml,
    first_difference,
    plain,
)
from tuner.safe_io import check_not_link, named, open_nofollow, read_text, refuse_links

#: what this module owns; the records it reads and writes (``Meta``, ``Best``, ``Checkpoint``, ``HistoryRow``,
#: ``RunError`` and the encodings) are :mod:`tuner.records`'s, importable from here as well
__all__ = ["RunDir", "History", "atomic_write", "read_chain", "check_chain", "CHAIN", "FAULT_ENV", "RunError"]

FAULT_ENV = "TUNER_FAULT_KILL_AT_WRITE"
LEGACY_CHECKPOINT = "checkpoint.pkl"

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
    """Write to a temporary file, fsync, rename: readers see the old or the new file, never half."""
    global _n_writes
    _n_writes += 1
    path = Path(path)
    tmp = path.with_name(f".{path.name}.tmp{os.getpid()}")
    check_not_link(path.parent)
    if os.path.lexists(tmp):
        os.unlink(tmp)  # a leftover of a killed process with this pid (a link is removed, not followed)
    try:
        with named(path):  # a full disk names the file, not `?`
            with os.fdopen(open_nofollow(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL), "wb") as fh:
                fh.write(data if isinstance(data, bytes) else data.encode())
                fh.flush()
                os.fsync(fh.fileno())
    except OSError:
        if os.path.lexists(tmp):
            os.unlink(tmp)  # nothing half-written stays behind; the old file is untouched
        raise
    _fault("before")
    os.replace(tmp, path)
    try:
        dfd = os.open(path.parent, os.O_RDONLY)
        try:
            os.fsync(dfd)
        finally:
            os.close(dfd)
    except OSError:  # pragma: no cover - some filesystems refuse directory fsync
        pass
    _fault("after")


def _append(path: Path, text: str) -> None:
    """Append and fsync (a kill can leave a torn last line, which the checkpoint's row count excludes)."""
    global _n_writes
    _n_writes += 1
    with named(path), os.fdopen(open_nofollow(path, os.O_WRONLY | os.O_APPEND | os.O_CREAT), "a", newline="") as fh:
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
    ``history.chain``: each row's digest chained to the row before and to ``config_hash`` (:mod:`tuner.digest`);
    an older history without it stays readable and is continued without digests."""

    def __init__(self, path: Path, param_names: list[str], config_hash: str = ""):
        self.path = Path(path)
        self.chain_path = self.path.with_name(CHAIN)
        self.param_names = list(param_names)
        self.metric_names: list[str] = []
        self.config_hash, self._last = config_hash, config_hash
        if self.path.exists():
            try:
                header = next(csv.reader(io.StringIO(read_text(self.path), newline="")), None)
            except (UnicodeDecodeError, csv.Error) as exc:
                raise RunError(f"{self.path}: unreadable ({exc})") from None
            fixed = FIXED_COLUMNS + self.param_names + RESULT_COLUMNS
            if header is None or header[:len(fixed)] != fixed:
                raise RunError(f"{self.path}: header {header} does not start with the expected columns {fixed}")
            self.metric_names = header[len(fixed):]
            self.chained = self.chain_path.exists()
            self._last = None  # read when first needed
        else:
            self.chained = True
            self._rewrite([])
            atomic_write(self.chain_path, "")

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
        if self.chained:
            digests = read_chain(self.chain_path)
            check_chain(self.path, rows[:n_rows], digests, self.config_hash)
            if len(digests) != n_rows:
                atomic_write(self.chain_path, "".join(f"{e},{d}\n" for e, d in digests[:n_rows]))
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
        if self.chained and self._last is None:
            digests = read_chain(self.chain_path)
            self._last = digests[-1][1] if digests else self.config_hash
        buf, lines = io.StringIO(), []
        w = csv.DictWriter(buf, fieldnames=self.columns, extrasaction="ignore", lineterminator="\n")
        for r in rows:
            w.writerow(r)
            if self.chained:
                self._last = digest.row_digest(str(self._last), r)
                lines.append(f"{r.get('eval')},{self._last}\n")
        _append(self.path, buf.getvalue())
        if lines:
            _append(self.chain_path, "".join(lines))


CHAIN = digest.CHAIN


def read_chain(path: Path) -> list[tuple[str, str]]:
    try:
        return digest.parse_chain(read_text(path))
    except UnicodeDecodeError as exc:
        raise RunError(f"{path}: unreadable ({exc})") from None


def check_chain(path: Path, rows: list[dict[str, str]], digests: list[tuple[str, str]], config_hash: str) -> None:
    """:class:`RunError` naming the first of ``rows`` that does not match ``history.chain`` (:mod:`tuner.digest`)."""
    if (bad := digest.first_mismatch(rows, digests, config_hash)) is not None:
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
        if not p.is_file():
            raise RunError(f"{p}: missing ({what})")
        try:
            return read_text(p)
        except (OSError, UnicodeDecodeError) as exc:
            raise RunError(f"{p}: unreadable: {exc}") from None

    def _json(self, name: str, what: str) -> Any:
        try:
            return json.loads(self._text(name, what))
        except json.JSONDecodeError as exc:
            raise RunError(f"{self.path / name}: not valid JSON: {exc}") from None

    def _yaml(self, name: str, what: str) -> Any:
        try:
            return safe_yaml.load(self._text(name, what))
        except yaml.YAMLError as exc:
            msg = safe_yaml.one_line(exc)
            raise RunError(f"{self.path / name}: not valid YAML: {msg}") from None

    def is_run(self) -> bool:
        return (self.path / "meta.json").is_file()

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
            return json.loads(read_text(p)) if p.is_file() else None
        except (OSError, ValueError):
            return None

    def has_best(self) -> bool:
        return (self.path / "best.yaml").is_file()

    def best(self) -> Best:
        return Best.from_doc(self._yaml("best.yaml", "nothing evaluated yet?"), self.path / "best.yaml")

    def checkpoint(self) -> Checkpoint | None:
        """The checkpoint, ``None`` if the run never completed a generation; a legacy pickle is refused."""
        if (self.path / LEGACY_CHECKPOINT).exists():
            raise RunError(f"{self.path / LEGACY_CHECKPOINT}: a pickled checkpoint from an older tuner; pickles "
                           "can run arbitrary code, so it is never loaded and this run cannot be resumed "
                           "(its history.csv and best.yaml stay readable; start the job again)")
        if not (self.path / "checkpoint.json").exists():
            return None
        return Checkpoint.from_doc(self._json("checkpoint.json", "checkpoint"), self.path / "checkpoint.json")

    def history(self, param_names: list[str], config_hash: str = "") -> History:
        return History(self.path / "history.csv", param_names, config_hash)

    def history_rows(self) -> list[dict[str, str]]:
        """The rows of ``history.csv`` as strings (empty when nothing was evaluated yet)."""
        p = self.path / "history.csv"
        if not p.is_file():
            return []
        try:
            return list(csv.DictReader(io.StringIO(read_text(p), newline="")))
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

    def write_checkpoint(self, ck: Checkpoint) -> None:
        atomic_write(self.path / "checkpoint.json", json.dumps(dataclasses.asdict(ck)))

    def validation(self) -> dict[str, Any] | None:
        """``validation.json`` (``None`` when the run has none)."""
        if not (self.path / "validation.json").is_file():
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
            p.unlink(missing_ok=True)
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
        fd = open_nofollow(self.path / ".lock", os.O_RDWR | os.O_CREAT)  # never truncate a link's target
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
