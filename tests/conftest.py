"""What every test shares: the repository root, the BROAD recordings, and the markers.

- ``REPO`` is the repository root (configs/, benchmarks/; pytest puts it on ``sys.path`` through
  ``pythonpath`` in pyproject.toml, so ``tests.reference`` and ``benchmarks`` import as packages).
- ``BROAD_DIR`` is ``../shared/data/broad`` beside the repository (or beside its parent, for a clone
  in a subfolder), computed once here; None when absent.
- The ``broad_dir`` fixture is that directory; a test that takes it, or is marked ``broad``, is skipped
  with the reason when the data is absent (and gets the ``broad`` marker, so ``-m "not broad"`` leaves
  it out).
- ``run_tuner`` runs the command line (in this process, or in a subprocess when asked);
  ``one_error_line`` asserts that a run ended in exactly one ``error:`` line with exit 2 and no traceback.
- ``slow`` marks the tests that take seconds each (tunings, subprocess runs, whole BROAD trials);
  ``make test-fast`` runs ``-m "not slow"``, ``make test`` (CI) runs everything.
"""

from __future__ import annotations

import contextlib
import io
import os
import re
import signal
import subprocess
import sys
from pathlib import Path

import pytest

# A test suite started in the background by a non-interactive shell (`cmd &`, `nohup`) inherits SIGINT (and,
# under nohup, SIGHUP) ignored, and so would every `tuner` the tests start: the tests that stop a run as a
# user or a scheduler would (Ctrl-C, SIGHUP) then see it go on. Give them the dispositions of a terminal.
if signal.getsignal(signal.SIGINT) is signal.SIG_IGN:
    signal.signal(signal.SIGINT, signal.default_int_handler)
if signal.getsignal(signal.SIGHUP) is signal.SIG_IGN:
    signal.signal(signal.SIGHUP, signal.SIG_DFL)

REPO = Path(__file__).resolve().parents[1]
BROAD_DIR: Path | None = next((p for p in (REPO.parent / "shared" / "data" / "broad",
                                           REPO.parent.parent / "shared" / "data" / "broad") if p.is_dir()), None)
_NO_BROAD = f"needs the BROAD recordings in {REPO.parent / 'shared' / 'data' / 'broad'}"


@pytest.fixture(scope="session")
def broad_dir() -> Path:
    """The BROAD directory (``*.mat`` trials, ``trials.json``, ``published_results.json``)."""
    if BROAD_DIR is None:
        pytest.skip(_NO_BROAD)
    return BROAD_DIR


def run_tuner(*args: str, cwd=None, env=None, timeout: float = 300, process: bool = False,
              check: bool = False) -> subprocess.CompletedProcess:
    """The command line ``tuner *args``, output captured as text, as a finished process.

    It runs in this process through :func:`tuner.cli.main` (stdout and stderr captured, the working
    directory changed for the call): a new interpreter would spend about 0.5 s importing numpy, numba and
    pandas for each call. ``python -m tuner`` runs in a subprocess when ``env`` is given (an environment is
    read at import) or ``process`` is set (what only a process shows: signals, exit status of the
    interpreter, modules a command imports). ``check``: assert exit status 0 (the message is stderr).
    """
    if env is not None or process:
        res = subprocess.run([sys.executable, "-m", "tuner", *args], capture_output=True, text=True, cwd=cwd,
                             timeout=timeout, env=env)
        assert not check or res.returncode == 0, res.stderr
        return res
    from tuner.cli import main

    out, err, here = io.StringIO(), io.StringIO(), os.getcwd()
    try:
        if cwd is not None:
            os.chdir(cwd)
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            try:
                code = main([str(a) for a in args])
            except SystemExit as exc:  # argparse: usage errors (2), --help and --version (0)
                code = exc.code if isinstance(exc.code, int) else int(exc.code is not None)
    finally:
        os.chdir(here)
    assert not check or code == 0, err.getvalue()
    return subprocess.CompletedProcess(["tuner", *args], code, out.getvalue(), err.getvalue())


def built_once(tmp_path_factory, name: str, build) -> Path:
    """A folder filled by ``build(folder)`` once per test session, also when pytest-xdist workers share the
    session: the first worker to ask builds it, the other waits for it. The tests only read it (a test that
    changes a run or a page works on a copy)."""
    import fcntl
    import shutil

    root = tmp_path_factory.getbasetemp()
    if os.environ.get("PYTEST_XDIST_WORKER"):
        root = root.parent  # the session's folder, above each worker's own
    folder, done = root / f"built-{name}", root / f"built-{name}.done"
    with open(root / f"built-{name}.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        if not done.exists():
            shutil.rmtree(folder, ignore_errors=True)  # a build that failed half-way
            folder.mkdir()
            build(folder)
            done.touch()
    return folder


@pytest.fixture(scope="module")
def browser(tmp_path_factory):
    """One headless Chromium for every page of a test module (each page in a browser context of its own;
    ``tests/tuner/browser.py``)."""
    from tests.tuner.browser import Browser

    with Browser(tmp_path_factory.mktemp("chromium")) as b:
        yield b


def readme_c_block(tag: str) -> str:
    """The C program of the README that follows ``<!-- tag -->`` (what the export tests compile against)."""
    text = (REPO / "README.md").read_text()
    return re.search(rf"<!-- {tag} -->\n```c\n(.*?)```", text, re.S).group(1)


def one_error_line(out: subprocess.CompletedProcess, *expected: str) -> str:
    """Assert that ``out`` is exit 2 with one ``error:`` line on stderr containing each of ``expected``
    and no traceback (``note:`` lines beside it are allowed); returns that line."""
    assert out.returncode == 2, (out.returncode, out.stdout, out.stderr)
    assert "Traceback" not in out.stderr, out.stderr
    lines = [ln for ln in out.stderr.splitlines() if ln.strip() and not ln.startswith("note:")]
    assert len(lines) == 1 and lines[0].startswith("error: "), out.stderr
    for e in expected:
        assert e in lines[0], (e, lines[0])
    return lines[0]



def refused_job(path: Path, capsys, expected: str) -> None:
    """``tuner run path`` in this process exits 2 with one ``error: <path>: ...`` line containing ``expected``
    and creates no run (the job's ``output`` is ``runs`` beside it)."""
    from tuner.cli import main

    assert main(["run", str(path)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith(f"error: {path}: ") and expected in err[0], err
    runs = path.parent / "runs"
    assert not runs.exists() or not any(runs.iterdir())

def pytest_collection_modifyitems(config, items):
    for item in items:
        if "broad_dir" in getattr(item, "fixturenames", ()):
            item.add_marker(pytest.mark.broad)
        if BROAD_DIR is None and item.get_closest_marker("broad") is not None:
            item.add_marker(pytest.mark.skip(reason=_NO_BROAD))
