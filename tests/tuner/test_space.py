"""Parameter space: encoding round trips, bounds, validation messages."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tuner.space import Real, Space, SpaceError

finite = st.floats(min_value=-1e6, max_value=1e6, allow_nan=False, allow_infinity=False)


@st.composite
def linear_params(draw):
    lo = draw(finite)
    width = draw(st.floats(min_value=1e-3, max_value=1e6))
    return Real("p", lo, lo + width)


@st.composite
def log_params(draw):
    lo_exp = draw(st.floats(min_value=-12, max_value=5))
    span = draw(st.floats(min_value=0.01, max_value=10))
    return Real("p", 10**lo_exp, 10 ** (lo_exp + span), scale="log")


@settings(max_examples=200, deadline=None)
@given(p=st.one_of(linear_params(), log_params()), u=st.floats(0, 1))
def test_unit_round_trip_stays_in_bounds(p, u):
    v = p.from_unit(u)
    assert p.low <= v <= p.high
    # float resolution of the bounds relative to the width limits the round trip
    tol = 1e-9 + 1e-14 * (abs(p.low) + abs(p.high)) / (p.high - p.low)
    assert p.to_unit(v) == pytest.approx(u, abs=tol)


@settings(max_examples=200, deadline=None)
@given(p=st.one_of(linear_params(), log_params()), u=st.floats(-5, 5))
def test_decode_clips_outside_cube(p, u):
    v = p.from_unit(u)
    assert p.low <= v <= p.high


@settings(max_examples=100, deadline=None)
@given(lo=st.integers(-1000, 1000), width=st.integers(0, 1000), u=st.floats(0, 1))
def test_integer_parameters_decode_to_integers_in_bounds(lo, width, u):
    p = Real("n", lo, lo + width + 0.5, integer=True)
    v = p.from_unit(u)
    assert isinstance(v, int) and lo <= v <= lo + width


@settings(max_examples=100, deadline=None)
@given(us=st.lists(st.floats(0, 1), min_size=3, max_size=3))
def test_space_encode_decode_round_trip(us):
    s = Space([Real("a", -1, 1), Real("b", 1e-6, 1, scale="log"), Real("mode", fixed="paper"),
               Real("c", 0, 10)])
    values = s.decode(np.array(us))
    assert values["mode"] == "paper"
    assert np.allclose(s.encode(values), us, atol=1e-9)


def test_log_scale_is_uniform_in_decades():
    p = Real("q", 1e-6, 1e-2, scale="log")
    assert p.from_unit(0.5) == pytest.approx(1e-4)
    assert p.from_unit(0.25) == pytest.approx(1e-5)


@pytest.mark.parametrize("kwargs, message", [
    ({"low": 1.0, "high": 1.0}, "need finite low < high, got low=1.0, high=1.0"),
    ({"low": 2.0, "high": 1.0}, "need finite low < high"),
    ({"low": 0.0, "high": 1.0, "scale": "log"}, "log scale needs low > 0, got low=0.0"),
    ({"low": -1.0, "high": 1.0, "scale": "log"}, "log scale needs low > 0"),
    ({"low": 0.0, "high": math.inf}, "need finite low < high"),
    ({"low": 0.0, "high": 1.0, "scale": "cubic"}, "scale must be 'linear' or 'log'"),
    ({"low": 0.2, "high": 0.8, "integer": True}, "no integer in"),
])
def test_bad_declarations_name_parameter_and_values(kwargs, message):
    with pytest.raises(SpaceError, match="beta") as exc:
        Real("beta", **kwargs)
    assert message in str(exc.value)


def test_from_dict_errors_and_fixed_values():
    s = Space.from_dict({"a": {"low": 0, "high": 1}, "b": 3.5, "c": {"fixed": "x"}})
    assert s.dim == 1 and s.fixed == {"b": 3.5, "c": "x"}
    with pytest.raises(SpaceError, match="unknown key"):
        Space.from_dict({"a": {"low": 0, "high": 1, "sclae": "log"}})
    with pytest.raises(SpaceError, match="missing"):
        Space.from_dict({"a": {"low": 0}})
    with pytest.raises(SpaceError, match="expected a number"):
        Space.from_dict({"a": {"low": "zero", "high": 1}})
    with pytest.raises(SpaceError, match="duplicate"):
        Space([Real("a", 0, 1), Real("a", 0, 2)])
    assert Space.from_dict(s.to_dict()) == s


def test_narrowed_space_contains_center_and_shrinks():
    s = Space([Real("a", 0, 10), Real("b", 1e-6, 1, scale="log"), Real("k", fixed=2)])
    center = {"a": 9.9, "b": 1e-3, "k": 2}
    n = s.narrowed(center, 0.2)
    assert n["a"].low <= 9.9 <= n["a"].high and n["a"].high == pytest.approx(10.0)
    assert n["a"].high - n["a"].low == pytest.approx(2.0)
    assert n["b"].low < 1e-3 < n["b"].high
    assert math.log10(n["b"].high / n["b"].low) == pytest.approx(1.2)
    assert n.fixed == {"k": 2}


def test_a_param_with_bounds_is_a_search_dimension():
    """``Real`` is a ``Param`` written by its bounds; a ``Space`` takes declared Params as they are."""
    from tuner.params import Param, ParamSet

    decl = ParamSet("demo", (Param("beta", 0.1, (1e-3, 1.0), "log", "rad/s"), Param("n", 3, (1, 9), integer=True),
                             Param("variant", "paper", choices=("paper", "c"))))
    space = Space(decl)
    assert space.dim == 2 and space.fixed == {"variant": "paper"} and space.free_names == ["beta", "n"]
    for u in ([0.5, 1.0], [0.0, 0.3], [0.77, 0.5]):
        assert space.decode(u) == decl.space().decode(u)
    assert space.decode([0.5, 1.0]) == {"beta": 10 ** -1.5, "n": 9, "variant": "paper"}
    assert space.to_dict() == decl.space().to_dict()
    assert isinstance(Real("x", 0, 1), Param) and Real("x", 0, 1).is_fixed is False
    assert Real.from_dict("beta", decl["beta"].to_dict()) == decl["beta"].real()
    assert decl["beta"].to_unit(0.1) == pytest.approx(2 / 3)
    with pytest.raises(SpaceError, match="log scale needs low > 0, got low=0.0"):
        Param("b", 0.1, (0.0, 1.0), "log")
    with pytest.raises(SpaceError, match="integer parameter has no integer"):
        Param("k", 1, (0.2, 0.8), integer=True)
