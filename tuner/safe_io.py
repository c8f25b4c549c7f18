"""The one way tuner opens a file of a run or sweep directory, for reading or writing.

A run or sweep directory is untrusted data: someone may hand one over, and what is inside it must not make
tuner read or write anything but its own regular files. Every read and write of such a directory goes through
this module, which refuses

- **symbolic links**: ``.lock -> ~/.bashrc`` or ``figures -> ~/``; every file is opened with ``O_NOFOLLOW``,
  and :func:`refuse_links` checks the entries of a directory (and of its ``figures/`` and ``jobs/`` folders)
  with ``lstat`` before use. The directory itself may be a link (``runs/latest -> ...`` is the user's own
  choice); what is inside it may not.
- **anything but a regular file**: a FIFO, a device or a socket. Files are opened with ``O_NONBLOCK`` and
  checked with ``fstat`` before a byte is read or written, so a FIFO named ``history.chain`` is an error, never
  a hang (opening a FIFO without ``O_NONBLOCK`` blocks until a writer appears).
- **hard links where tuner writes**: a file with another name (``st_nlink > 1``) is never written to,
  appended to, truncated or replaced: a ``.lock`` hard-linked to a file elsewhere would be truncated to the
  pid, a hard-linked ``history.csv`` would grow another run's history. Reading a hard-linked file is allowed
  (its content is data like any other; ``cp -al`` and backup snapshots make such links).
- **files over a size limit** (:data:`MAX_READ_BYTES`, or the caller's ``limit``): read whole into memory,
  a file of any size would be an out-of-memory crash.

Each refusal is an :class:`UnsafeFile` (an ``OSError`` naming the file; the command line prints it as one
``error:`` line, exit 2). Writes are atomic (:func:`write_atomic`: a temporary file, ``fsync``, a rename) but
for the history's appends and the lock (:func:`open_append`, :func:`open_lock`).
"""

from __future__ import annotations

import errno
import fcntl
import os
import stat
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import IO

__all__ = ["UnsafeFile", "LinkRefused", "MAX_READ_BYTES", "refuse_links", "check_not_link", "named", "regular",
           "read_bytes", "read_text", "open_append", "open_lock", "write_atomic", "open_nofollow"]

#: folders of a run or sweep directory whose entries are checked too
SUBDIRS = ("figures", "jobs", "repeats")
#: those of them that hold run directories (a sweep's jobs, a repeated run's repeats), checked in turn
NESTED = ("jobs", "repeats")
#: the largest file read whole from a run or sweep directory (bytes); a history of a million evaluations with a
#: dozen metrics is about 200 MB
MAX_READ_BYTES = 512 * 2**20

_KINDS = {stat.S_IFIFO: "a FIFO (named pipe)", stat.S_IFCHR: "a character device", stat.S_IFBLK: "a block device",
          stat.S_IFSOCK: "a socket", stat.S_IFDIR: "a directory", stat.S_IFLNK: "a symbolic link"}


class UnsafeFile(OSError):
    """A file of a run or sweep directory that tuner does not read or write (an ``OSError`` naming it)."""

    def __init__(self, path: Path | str, what: str, code: int = errno.EPERM):
        super().__init__(code, what, str(path))


class LinkRefused(UnsafeFile):
    """A symbolic link inside a run or sweep directory."""

    def __init__(self, path: Path | str):
        super().__init__(path, "a symbolic link inside a run or sweep directory; refused (a run directory is "
                               "data: tuner never follows links in it)", errno.ELOOP)


def _kind(mode: int) -> str:
    return _KINDS.get(stat.S_IFMT(mode), "not a regular file")


def _refuse_special(path: Path | str, st: os.stat_result) -> None:
    if stat.S_ISLNK(st.st_mode):
        raise LinkRefused(path)
    if not stat.S_ISREG(st.st_mode):
        raise UnsafeFile(path, f"{_kind(st.st_mode)}, not a regular file; refused (tuner reads and writes only "
                               "regular files in a run or sweep directory)")


def _refuse_hard_link(path: Path | str, st: os.stat_result) -> None:
    if st.st_nlink > 1:
        raise UnsafeFile(path, f"a hard link ({st.st_nlink} names share this file); refused: tuner never writes a "
                               "file another name shares (copy the directory with `cp -a`, not `cp -al`)")


def check_not_link(path: Path | str) -> None:
    """Refuse ``path`` if it is a symbolic link (a missing path is fine)."""
    try:
        st = os.lstat(path)
    except FileNotFoundError:
        return
    if stat.S_ISLNK(st.st_mode):
        raise LinkRefused(path)


def refuse_links(directory: Path | str, depth: int = 2) -> None:
    """Refuse a directory holding a symbolic link among its entries, the entries of its ``figures/``, ``jobs/``
    and ``repeats/`` folders and the entries of each run directory in the last two (a sweep's jobs, a repeated
    run's repeats)."""
    directory = Path(directory)
    try:
        entries = list(os.scandir(directory))
    except (FileNotFoundError, NotADirectoryError):
        return
    for e in entries:
        if e.is_symlink():
            raise LinkRefused(e.path)
        if depth > 0 and e.name in SUBDIRS and e.is_dir(follow_symlinks=False):
            for sub in os.scandir(e.path):
                if sub.is_symlink():
                    raise LinkRefused(sub.path)
                if e.name in NESTED and sub.is_dir(follow_symlinks=False):
                    refuse_links(sub.path, depth - 1)


def regular(path: Path | str) -> bool:
    """True for a regular file at ``path``, False when nothing is there; anything else (a link, a FIFO, a
    device, a socket, a directory) is :class:`UnsafeFile`. The check to use before reading a file that may be
    absent, instead of ``exists()`` or ``is_file()`` (which follow links and call a FIFO "not a file")."""
    try:
        st = os.lstat(path)
    except (FileNotFoundError, NotADirectoryError):
        return False
    _refuse_special(path, st)
    return True


@contextmanager
def named(path: Path | str) -> Iterator[None]:
    """Give an ``OSError`` raised without a file name (a write on a full disk) the name of ``path``."""
    try:
        yield
    except OSError as exc:
        if exc.filename is None:
            raise OSError(exc.errno, exc.strerror or str(exc), str(path)) from exc
        raise


def open_nofollow(path: Path | str, flags: int, mode: int = 0o644) -> int:
    """``os.open`` with ``O_NOFOLLOW``, ``O_NONBLOCK`` and close-on-exec; a link at ``path`` is
    :class:`LinkRefused`, a FIFO, device or socket :class:`UnsafeFile` (checked with ``fstat``: never blocks).
    The descriptor is returned blocking again."""
    try:
        fd = os.open(path, flags | os.O_NOFOLLOW | os.O_NONBLOCK | getattr(os, "O_CLOEXEC", 0), mode)
    except OSError as exc:
        if exc.errno == errno.ELOOP:
            raise LinkRefused(path) from None
        if exc.errno == errno.ENXIO:  # a FIFO opened for writing with no reader
            raise UnsafeFile(path, "a FIFO (named pipe), not a regular file; refused") from None
        raise
    try:
        _refuse_special(path, os.fstat(fd))
        fcntl.fcntl(fd, fcntl.F_SETFL, fcntl.fcntl(fd, fcntl.F_GETFL) & ~os.O_NONBLOCK)
    except BaseException:
        os.close(fd)
        raise
    return fd


def read_bytes(path: Path | str, limit: int | None = None) -> bytes:
    """The content of the regular file ``path`` (no link followed, no FIFO opened, at most ``limit`` bytes,
    default :data:`MAX_READ_BYTES`)."""
    limit = MAX_READ_BYTES if limit is None else limit
    fd = open_nofollow(path, os.O_RDONLY)
    with os.fdopen(fd, "rb") as fh:
        size = os.fstat(fd).st_size
        if size > limit:
            raise UnsafeFile(path, f"{size:,} bytes, more than the {limit:,} tuner reads from a run or sweep "
                                   "directory; refused", errno.EFBIG)
        data = fh.read(limit + 1)
    if len(data) > limit:  # grew while read
        raise UnsafeFile(path, f"more than the {limit:,} bytes tuner reads from a run or sweep directory; refused",
                         errno.EFBIG)
    return data


def read_text(path: Path | str, limit: int | None = None) -> str:
    """The file's text (UTF-8) under the rules of :func:`read_bytes` (``UnicodeDecodeError`` for binary content)."""
    return read_bytes(path, limit).decode("utf-8")


def _writable(path: Path | str, fd: int) -> int:
    try:
        _refuse_hard_link(path, os.fstat(fd))
    except BaseException:
        os.close(fd)
        raise
    return fd


def open_append(path: Path | str) -> int:
    """A descriptor appending to the regular file ``path`` (created if absent); a link of either kind or a
    special file is refused before a byte is written."""
    return _writable(path, open_nofollow(path, os.O_WRONLY | os.O_APPEND | os.O_CREAT))


def open_lock(path: Path | str) -> int:
    """A read-write descriptor of the lock file ``path`` (created if absent, never truncated here); a link of
    either kind or a special file is refused."""
    return _writable(path, open_nofollow(path, os.O_RDWR | os.O_CREAT))


def write_atomic(path: Path | str, data: bytes | str | Callable[[IO[bytes]], None], *, fsync: bool = True,
                 before_replace: Callable[[], None] | None = None) -> Path:
    """Write ``data`` (bytes, text as UTF-8, or a function writing into the open binary file) to a temporary
    file beside ``path``, then rename it over ``path``: a reader sees the old or the new file, never half.

    ``path`` may be absent or a regular file with no other name; a link of either kind or a special file
    there is refused before anything is written. With ``fsync`` the file and the directory are synced
    (records); without (reports, figures) the rename alone makes the write atomic. ``before_replace`` is
    called between the write and the rename (the fault-injection hook of :mod:`tuner.rundir`).
    """
    path = Path(path)
    check_not_link(path.parent)
    try:
        st = os.lstat(path)
    except (FileNotFoundError, NotADirectoryError):
        st = None
    if st is not None:
        _refuse_special(path, st)
        _refuse_hard_link(path, st)
    tmp = path.with_name(f".{path.name}.tmp{os.getpid()}")
    if os.path.lexists(tmp):
        os.unlink(tmp)  # a leftover of a killed process with this pid (a link is removed, not followed)
    try:
        with named(path):  # a full disk names the file, not `?`
            with os.fdopen(open_nofollow(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL), "wb") as fh:
                if callable(data):
                    data(fh)
                else:
                    fh.write(data if isinstance(data, bytes) else data.encode("utf-8"))
                fh.flush()
                if fsync:
                    os.fsync(fh.fileno())
        if before_replace is not None:
            before_replace()
        os.replace(tmp, path)
    except BaseException:  # a full disk, a Ctrl-C or SIGTERM: no temporary file stays behind, the old file is kept
        if os.path.lexists(tmp):
            os.unlink(tmp)
        raise
    if fsync:
        try:
            dfd = os.open(path.parent, os.O_RDONLY)
            try:
                os.fsync(dfd)
            finally:
                os.close(dfd)
        except OSError:  # pragma: no cover - some filesystems refuse directory fsync
            pass
    return path
