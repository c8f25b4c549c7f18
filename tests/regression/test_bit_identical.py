"""Migration guard: filter outputs and short run histories are bit-identical to those computed before the
code moved into its present rooms (``pinned_digests.json``, see :mod:`tests.regression.digests`).

A refactoring that changes one of these digests changed a result, not only where code lives. The digests
are of float64 bytes from numba kernels, so they hold for the platform they were computed on (x86-64
Linux, the CI machine); a change of numba or NumPy version that changes rounding shows up here too.
"""

from __future__ import annotations

import json

import pytest

from tests.regression.digests import FILTER_CASES, PINNED, filter_digests, run_digests

EXPECTED = json.loads(PINNED.read_text())


def test_every_case_is_pinned():
    assert set(EXPECTED["filters"]) == {label for label, *_ in FILTER_CASES}


def test_filter_outputs_bit_identical():
    got = filter_digests()
    changed = {k: (EXPECTED["filters"][k], v) for k, v in got.items() if EXPECTED["filters"][k] != v}
    assert not changed, f"filter outputs changed (pinned, now): {changed}"


@pytest.mark.slow
def test_run_histories_bit_identical(tmp_path):
    got = run_digests(tmp_path)
    changed = {k: (EXPECTED["runs"][k], v) for k, v in got.items() if EXPECTED["runs"][k] != v}
    assert not changed, f"run histories changed (pinned, now): {changed}"
