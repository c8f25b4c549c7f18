"""A run or sweep directory is untrusted data: nothing inside it is followed through a symbolic link.

A handed-over directory could hold ``.lock -> ~/.bashrc`` or ``figures -> ~/``: writing the lock, a figure
or the history would then truncate or overwrite the user's files, and reading ``history.csv -> ~/.ssh/...``
would copy them into a report. So the entries of a run directory (and of its ``figures/``, and the job
directories of a sweep) are checked with ``lstat`` before use, and the files tuner writes or appends to
are opened with ``O_NOFOLLOW``. The directory itself may be a link (``runs/latest -> ...`` is the user's
own choice); what is inside it may not.
"""

from __future__ import annotations

import errno
import os
import stat
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

__all__ = ["LinkRefused", "refuse_links", "named", "open_nofollow", "read_bytes", "read_text", "check_not_link"]

#: folders of a run or sweep directory whose entries are checked too
SUBDIRS = ("figures", "jobs", "repeats")
#: those of them that hold run directories (a sweep's jobs, a repeated run's repeats), checked in turn
NESTED = ("jobs", "repeats")


class LinkRefused(OSError):
    """A symbolic link inside a run or sweep directory (an ``OSError`` naming the file: exit 2)."""

    def __init__(self, path: Path | str):
        super().__init__(errno.ELOOP, "a symbolic link inside a run or sweep directory; refused (a run directory "
                                      "is data: tuner never follows links in it)", str(path))


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
    """``os.open`` with ``O_NOFOLLOW`` (and close-on-exec); a link at ``path`` is :class:`LinkRefused`."""
    try:
        return os.open(path, flags | os.O_NOFOLLOW | getattr(os, "O_CLOEXEC", 0), mode)
    except OSError as exc:
        if exc.errno == errno.ELOOP:
            raise LinkRefused(path) from None
        raise


def read_bytes(path: Path | str) -> bytes:
    fd = open_nofollow(path, os.O_RDONLY)
    with os.fdopen(fd, "rb") as fh:
        return fh.read()


def read_text(path: Path | str) -> str:
    """The file's text (UTF-8), never through a link (``UnicodeDecodeError`` for binary content)."""
    return read_bytes(path).decode("utf-8")
