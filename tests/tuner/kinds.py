"""Objective kinds registered for one test only."""

from __future__ import annotations

import pytest

from tuner.registry import REGISTRY


def kind_fixture(fixture: str, kind: str, cls: type):
    """A pytest fixture named ``fixture`` that registers ``cls`` as objective ``kind`` for one test, yields the
    kind's name and removes it afterwards."""

    @pytest.fixture(name=fixture)
    def registered():
        REGISTRY.register(kind, cls, "tests")
        yield kind
        REGISTRY._specs.pop(kind, None)

    return registered


class CountingObjective:
    """Counts the calls made on this copy and returns the count as fitness: a copy kept by a worker
    process counts on across batches, a fresh copy per task starts again at 1."""

    def __init__(self) -> None:
        self.calls = 0

    def __call__(self, params: dict) -> float:
        self.calls += 1
        return float(self.calls)
