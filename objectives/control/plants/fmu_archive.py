"""An FMU file opened as untrusted data: checked before any part of it is parsed, unpacked or loaded.

An ``.fmu`` is a zip archive holding ``modelDescription.xml`` and the native library the loop calls. A file
that is not one, or one built to harm, must be one ``error:`` line, and what tuner unpacks must not outlive
the process:

- **not a zip** (or a damaged one): ``ValueError`` naming the key.
- **the archive's entries**: at most :data:`MAX_ENTRIES`, at most :data:`MAX_UNPACKED_BYTES` unpacked in all
  (counted from the headers and again while unpacking: a 2 MB file cannot fill the disk), no entry whose
  name leaves the extraction folder (absolute, ``..``, a backslash or a drive) and no symbolic-link entry.
- **modelDescription.xml**: at most :data:`MAX_XML_BYTES`, parsed first by the standard library's expat
  with any document type declaration refused (FMI needs none; a DTD is how an entity bomb or an external
  entity gets in), and only then handed to fmpy, as exactly the bytes checked. Its ``modelIdentifier``
  (which names the library to load) must be a C identifier, so it cannot point outside the folder.
- **extraction folders** (``tuner-fmu-<pid>-*`` in the temporary directory, mode 0700) belong to the process
  that made them: removed when the plant using it is garbage-collected, at the process's exit (workers
  included: they exit through ``sys.exit``), and on a Ctrl-C (which ends in one of those). A process killed
  outright (``kill -9``, a pool's terminate after a Ctrl-C) cannot clean up: at its exit the process that
  started it, and at the next extraction any process of the user, removes the folders of processes that no
  longer exist.
"""

from __future__ import annotations

import atexit
import io
import os
import re
import shutil
import stat
import tempfile
import weakref
import xml.parsers.expat
import zipfile
from pathlib import Path, PurePosixPath
from typing import Any

__all__ = ["read_description", "extract", "attach_cleanup", "MAX_ENTRIES", "MAX_UNPACKED_BYTES", "MAX_XML_BYTES",
           "PREFIX"]

#: the most entries an FMU may hold (a real one has tens: the XML, sources, one library per platform)
MAX_ENTRIES = 10_000
#: the most bytes an FMU may unpack to (real ones are a few MB to some tens of MB with every platform)
MAX_UNPACKED_BYTES = 512 * 2**20
#: the largest modelDescription.xml read (large models with thousands of variables are a few MB)
MAX_XML_BYTES = 64 * 2**20
#: the name prefix of extraction folders (then the pid of the process that owns it)
PREFIX = "tuner-fmu-"
_OWN = re.compile(re.escape(PREFIX) + r"(\d+)-")
_live: set[str] = set()


class _Refused(Exception):
    pass


def _open_zip(path: Path, key: str) -> zipfile.ZipFile:
    try:
        return zipfile.ZipFile(path)
    except (zipfile.BadZipFile, zipfile.LargeZipFile, EOFError, ValueError, NotImplementedError) as exc:
        raise ValueError(f"{key}: {path.name} is not an FMU: not a zip archive ({exc})") from None


def _check_entries(zf: zipfile.ZipFile, path: Path, key: str) -> list[zipfile.ZipInfo]:
    infos = zf.infolist()
    if len(infos) > MAX_ENTRIES:
        raise ValueError(f"{key}: {path.name} holds {len(infos):,} entries; at most {MAX_ENTRIES:,} are unpacked")
    total = 0
    for info in infos:
        name = info.filename
        parts = PurePosixPath(name).parts
        if "\\" in name or ":" in name or name.startswith("/") or ".." in parts or "\x00" in name:
            raise ValueError(f"{key}: {path.name}: entry {name!r} would be unpacked outside its folder; refused")
        if stat.S_ISLNK(info.external_attr >> 16):
            raise ValueError(f"{key}: {path.name}: entry {name!r} is a symbolic link; refused")
        total += info.file_size
        if total > MAX_UNPACKED_BYTES:
            raise ValueError(f"{key}: {path.name} unpacks to more than {MAX_UNPACKED_BYTES // 2**20} MB; refused "
                             "(a zip bomb?)")
    return infos


def _check_xml(xml_bytes: bytes, path: Path, key: str) -> None:
    """Well-formed XML without a document type declaration (so without entities), by expat."""
    parser = xml.parsers.expat.ParserCreate()

    def refuse(*_: Any) -> None:
        raise _Refused()

    parser.StartDoctypeDeclHandler = refuse
    parser.EntityDeclHandler = refuse
    parser.ExternalEntityRefHandler = refuse
    try:
        parser.Parse(xml_bytes, True)
    except _Refused:
        raise ValueError(f"{key}: {path.name}: modelDescription.xml declares a document type or entities, which "
                         "FMI never needs; refused (an entity bomb or an external entity?)") from None
    except xml.parsers.expat.ExpatError as exc:
        raise ValueError(f"{key}: {path.name}: modelDescription.xml is not well-formed XML ({exc})") from None


def read_description(path: str | Path, key: str) -> Any:
    """fmpy's ``ModelDescription`` of the FMU at ``path``, after the checks of the module docstring (nothing is
    unpacked); ``ValueError`` naming ``key`` for a file that is not a sound FMU."""
    from fmpy import read_model_description

    path = Path(path)
    with _open_zip(path, key) as zf:
        _check_entries(zf, path, key)
        try:
            info = zf.getinfo("modelDescription.xml")
        except KeyError:
            raise ValueError(f"{key}: {path.name} is not an FMU: no modelDescription.xml in the archive") from None
        if info.file_size > MAX_XML_BYTES:
            raise ValueError(f"{key}: {path.name}: modelDescription.xml is over {MAX_XML_BYTES // 2**20} MB; refused")
        try:
            with zf.open(info) as fh:
                xml_bytes = fh.read(MAX_XML_BYTES + 1)
        except (zipfile.BadZipFile, OSError, EOFError, NotImplementedError, RuntimeError) as exc:
            raise ValueError(f"{key}: {path.name}: modelDescription.xml cannot be read ({exc})") from None
    _check_xml(xml_bytes, path, key)
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w") as z:  # fmpy parses exactly the bytes checked above
        z.writestr("modelDescription.xml", xml_bytes)
    buf.seek(0)
    try:
        md = read_model_description(buf)
    except Exception as exc:  # noqa: BLE001 - fmpy raises plain Exception, lxml and validation errors
        text = (str(exc).strip().splitlines() or [type(exc).__name__])[-1]
        raise ValueError(f"{key}: {path.name} is not a valid FMU ({text})") from None
    for kind in ("coSimulation", "modelExchange"):
        ident = getattr(getattr(md, kind, None), "modelIdentifier", None)
        if ident is not None and not (ident.isidentifier() and ident.isascii()):
            raise ValueError(f"{key}: {path.name}: modelIdentifier {ident!r} is not a C identifier; refused (it "
                             "names the library to load)")
    return md


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def _sweep_stale() -> None:
    """Remove extraction folders of the user's processes that no longer exist (killed before cleaning up)."""
    root = Path(tempfile.gettempdir())
    try:
        entries = list(os.scandir(root))
    except OSError:
        return
    for e in entries:
        m = _OWN.match(e.name)
        if not m or int(m.group(1)) == os.getpid():
            continue
        try:
            st = e.stat(follow_symlinks=False)
        except OSError:
            continue
        if stat.S_ISDIR(st.st_mode) and st.st_uid == os.getuid() and not _alive(int(m.group(1))):
            shutil.rmtree(e.path, ignore_errors=True)


def _remove(folder: str, owner: int) -> None:
    """Remove an extraction folder, only in the process that made it (a forked child inherits the registry)."""
    if os.getpid() == owner:
        _live.discard(folder)
        try:
            shutil.rmtree(folder, ignore_errors=True)
        except KeyboardInterrupt:  # a stop signal mid-removal (a pool's SIGTERM after a Ctrl-C): finish, then stop
            shutil.rmtree(folder, ignore_errors=True)
            raise


@atexit.register
def _remove_all() -> None:
    """At exit: this process's folders, and those of processes that ended without cleaning up (workers a pool
    killed on Ctrl-C end before the process that started them)."""
    for folder in list(_live):
        try:
            _remove(folder, os.getpid())
        except KeyboardInterrupt:  # the process is ending anyway: the other folders go too, with no traceback
            pass
    _sweep_stale()


def extract(path: str | Path, key: str) -> Path:
    """Unpack the FMU at ``path`` into a new folder of this process (see the module docstring) and return it.
    The caller hands it to :func:`attach_cleanup`; until then :func:`_remove_all` removes it at exit."""
    path = Path(path)
    _sweep_stale()
    folder = Path(tempfile.mkdtemp(prefix=f"{PREFIX}{os.getpid()}-"))
    _live.add(str(folder))
    try:
        with _open_zip(path, key) as zf:
            budget = MAX_UNPACKED_BYTES
            for info in _check_entries(zf, path, key):
                target = folder.joinpath(*PurePosixPath(info.filename).parts)
                if info.is_dir():
                    target.mkdir(parents=True, exist_ok=True)
                    continue
                target.parent.mkdir(parents=True, exist_ok=True)
                fd = os.open(target, os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_NOFOLLOW, 0o700)
                with zf.open(info) as src, os.fdopen(fd, "wb") as dst:
                    while chunk := src.read(2**20):
                        budget -= len(chunk)
                        if budget < 0:
                            raise ValueError(f"{key}: {path.name} unpacks to more than "
                                             f"{MAX_UNPACKED_BYTES // 2**20} MB; refused (a zip bomb?)")
                        dst.write(chunk)
    except BaseException as exc:
        _remove(str(folder), os.getpid())
        if isinstance(exc, (zipfile.BadZipFile, OSError, EOFError, NotImplementedError, RuntimeError)):
            raise ValueError(f"{key}: {path.name} cannot be unpacked ({exc})") from None
        raise
    return folder


def attach_cleanup(owner: Any, folder: Path, release: Any = None) -> None:
    """Remove ``folder`` when ``owner`` is garbage-collected (or at exit), after calling ``release()`` (e.g.
    freeing the FMU instance); only in this process."""
    def done(folder: str = str(folder), pid: int = os.getpid(), release: Any = release) -> None:
        if release is not None and os.getpid() == pid:
            try:
                release()
            except Exception:  # noqa: BLE001 - a native library's cleanup must not stop the removal
                pass
        try:
            _remove(folder, pid)
        except KeyboardInterrupt:
            # raised inside a finalizer, Python would print it and drop it ("Exception ignored"): the removal is
            # finished and the process is already stopping on the signal before it
            pass

    weakref.finalize(owner, done)
