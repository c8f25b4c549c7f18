"""What every test shares: the repository root, the BROAD recordings, and the markers.

- ``REPO`` is the repository root (configs/, benchmarks/; pytest puts it on ``sys.path`` through
  ``pythonpath`` in pyproject.toml, so ``tests.reference`` and ``benchmarks`` import as packages).
- ``BROAD_DIR`` is ``../shared/data/broad`` beside the repository (or beside its parent, for a clone
  in a subfolder), computed once here; None when absent.
- The ``broad_dir`` fixture is that directory; a test that takes it, or is marked ``broad``, is skipped
  with the reason when the data is absent (and gets the ``broad`` marker, so ``-m "not broad"`` leaves
  it out).
- ``slow`` marks the tests that take seconds each (tunings, subprocess runs, whole BROAD trials);
  ``make test-fast`` runs ``-m "not slow"``, ``make test`` (CI) runs everything.
"""

from __future__ import annotations

from pathlib import Path

import pytest

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


def pytest_collection_modifyitems(config, items):
    for item in items:
        if "broad_dir" in getattr(item, "fixturenames", ()):
            item.add_marker(pytest.mark.broad)
        if BROAD_DIR is None and item.get_closest_marker("broad") is not None:
            item.add_marker(pytest.mark.skip(reason=_NO_BROAD))
