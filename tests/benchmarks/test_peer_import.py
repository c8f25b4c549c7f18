"""Importing a peer library leaves nothing in the working directory (pyswarms writes report.log on import)."""

from __future__ import annotations

import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
if str(REPO) not in sys.path:  # benchmarks/ is not an installed package; `make bench` runs it from the root
    sys.path.insert(0, str(REPO))

from benchmarks.common import peer  # noqa: E402


def test_peer_import_writes_no_file_into_the_working_directory(tmp_path, monkeypatch):
    lib = tmp_path / "lib"
    lib.mkdir()
    (lib / "noisy_peer_lib.py").write_text("open('report.log', 'w').write('log')\nVALUE = 3\n")
    work = tmp_path / "work"
    work.mkdir()
    monkeypatch.chdir(work)
    monkeypatch.syspath_prepend(str(lib))
    monkeypatch.delitem(sys.modules, "noisy_peer_lib", raising=False)
    mod = peer("noisy_peer_lib")
    assert mod is not None and mod.VALUE == 3
    assert list(work.iterdir()) == [] and Path.cwd() == work
    assert peer("no_such_peer_library_here") is None and Path.cwd() == work
