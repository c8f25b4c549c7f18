"""The files tuner puts beside a report page (``plotly.min.js``, ``tuner_report.js``), checked by their content.

A report page runs the scripts of its own folder, so what lies there decides what runs in the user's browser
when they open a report tuner just wrote. A file of the right name is therefore never trusted for its name or
its size: :func:`install` compares the SHA-256 of what is there with that of the installed package's file and
replaces anything else. Where the file system allows, the file is a hard link (4.8 MB for plotly, once per
folder would add up) to a copy in one of the three folders above (a sweep or dashboard folder holding the
runs), but only a copy whose content hash matches at the moment of linking, that is a regular file (no
symbolic link) owned by the user or by root and writable by no one else (a file another user may write would
change the linked page's script later). Otherwise the file is copied from the package, never linked to it: a
write into a report folder's copy (``echo > plotly.min.js``) would otherwise change the installed package,
and with it every later report.
"""

from __future__ import annotations

import hashlib
import os
import stat
from pathlib import Path

from tuner.safe_io import UnsafeFile, read_bytes, write_atomic

__all__ = ["install", "sha256_of"]

#: how many folders above a report folder are searched for a copy to hard-link
NEAR_LEVELS = 3
_hashes: dict[tuple[str, int, int, int], str] = {}  # (path, inode, size, mtime_ns) -> sha256 of the package files


def sha256_of(path: Path) -> str | None:
    """SHA-256 of the regular file ``path`` (None when absent, a link, a special file or unreadable)."""
    try:
        return hashlib.sha256(read_bytes(path)).hexdigest()
    except (UnsafeFile, OSError):
        return None


def _package_hash(src: Path) -> str:
    st = os.stat(src)
    key = (str(src), st.st_ino, st.st_size, st.st_mtime_ns)
    if key not in _hashes:
        _hashes[key] = hashlib.sha256(src.read_bytes()).hexdigest()
    return _hashes[key]


def _linkable(cand: Path, want: str) -> bool:
    """A candidate for a hard link: a regular file (not a link) owned by the user or root, writable by no one
    else, with the wanted content."""
    try:
        st = os.lstat(cand)
    except OSError:
        return False
    if not stat.S_ISREG(st.st_mode) or st.st_uid not in (os.getuid(), 0) or st.st_mode & 0o022:
        return False
    return sha256_of(cand) == want


def install(folder: str | Path, name: str, src: str | Path) -> Path:
    """Make ``folder/name`` hold exactly the content of the installed file ``src``; returns its path.

    A file already there with the same SHA-256 is kept; anything else (another content of any size, a link, a
    FIFO) is replaced. The new file is a hard link to a matching copy up to :data:`NEAR_LEVELS` folders above,
    else a copy of ``src`` (see the module docstring).
    """
    folder, src = Path(folder), Path(src)
    want = _package_hash(src)
    dst = folder / name
    if sha256_of(dst) == want:
        return dst
    tmp = folder / f".{name}.tmp{os.getpid()}"
    if os.path.lexists(tmp):
        os.unlink(tmp)
    near = [a / name for a in list(folder.resolve().parents)[:NEAR_LEVELS]]
    try:
        for cand in near:
            if _linkable(cand, want):
                try:
                    os.link(cand, tmp)
                except OSError:
                    continue
                if sha256_of(tmp) == want:  # the linked file is what was checked
                    os.replace(tmp, dst)
                    return dst
                os.unlink(tmp)
    except BaseException:
        if os.path.lexists(tmp):
            os.unlink(tmp)
        raise
    if os.path.lexists(dst) and not stat.S_ISREG(os.lstat(dst).st_mode):
        os.unlink(dst)  # a link or a FIFO planted under the name: removed (never followed), then written
    elif os.path.lexists(dst) and os.lstat(dst).st_nlink > 1:
        os.unlink(dst)  # a hard link whose content differs: this name gets its own file
    write_atomic(dst, src.read_bytes(), fsync=False)
    return dst
