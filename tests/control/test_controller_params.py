"""Controller parameter declarations: previous defaults and spaces, units, validation of every value."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from objectives.control.controllers import get_controller

BEFORE = json.loads((Path(__file__).resolve().parents[1] / "reference" / "declarations_before.json").read_text())
NAMES = sorted(BEFORE["controllers"])


@pytest.mark.parametrize("name", NAMES)
def test_declaration_reproduces_previous_defaults_and_space(name):
    cls = get_controller(name)
    before = BEFORE["controllers"][name]
    assert dict(cls.defaults) == before["defaults"]
    space = cls.default_space().to_dict()
    assert list(space) == list(before["space"])
    for key, old in before["space"].items():
        for field, value in old.items():
            assert space[key][field] == value, (name, key, field)


@pytest.mark.parametrize("name", NAMES)
def test_describe_lists_every_parameter_with_unit_and_source(name):
    cls = get_controller(name)
    rows = {p["name"]: p for p in cls.describe()["params"]}
    assert set(rows) == set(cls.defaults)
    for key, row in rows.items():
        assert row["doc"] and row["eq"], (name, key)
        if row["kind"] == "number":
            assert row["unit"], (name, key)


@pytest.mark.parametrize("name", NAMES)
def test_bad_values_name_controller_key_and_range(name):
    cls = get_controller(name)
    c = cls()
    key = next(p.name for p in cls.declaration() if p.kind == "number")
    for bad in (float("nan"), math.inf, "12"):
        with pytest.raises(ValueError, match=f"controller '{name}': {key} must be") as exc:
            c.param_array({key: bad})
        assert repr(bad) in str(exc.value)


def test_declared_ranges():
    pid, lqr, lut = get_controller("pid")(), get_controller("lqr")(), get_controller("lut")()
    with pytest.raises(ValueError, match=r"yaw_range_deg_s must be in \(0, inf\) deg/s, got -1.0"):
        pid.param_array({"yaw_range_deg_s": -1.0})
    with pytest.raises(ValueError, match=r"r_u1 must be in \(0, inf\) 1/V\^2, got 0.0"):
        lqr.param_array({"r_u1": 0.0})
    with pytest.raises(ValueError, match=r"q_nu must be in \[0, inf\)"):
        lqr.param_array({"q_nu": -2.0})
    with pytest.raises(ValueError, match=r"lut_mode must be one of \[0, 1\], got 2"):
        lut.param_array({"lut_mode": 2})
    # integers given as floats are accepted and give the same kernel parameters
    np.testing.assert_array_equal(pid.param_array({"kp1": 12}), pid.param_array({"kp1": 12.0}))
