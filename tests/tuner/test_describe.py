"""`tuner describe NAME` and `tuner list metrics|data`: every listed name is described, with values
equal to the declarations the filters, controllers and optimisers themselves use."""

import math

import pytest

from tuner.cli import main
from tuner.describe import UnknownName, all_names, describe
from tuner.export_formats import json_load
from tuner.optimizers import OPTIMIZERS
from tuner.registry import REGISTRY


def test_every_listed_name_is_described():
    names = all_names()
    assert {"ekf", "lqr", "pso", "euler_mse_geomean", "mae_weighted_cost", "bench6dof", "csv", "broad",
            "thesis_2s", "filter", "closed_loop"} <= set(names)
    for name in names:
        found = describe(name)
        assert found and all(d["name"] == name and d["section"] for d in found), name


@pytest.mark.parametrize("section", ["filters", "controllers"])
def test_parameters_equal_the_declaration(section):
    from objectives.attitude.filters import get_filter
    from objectives.control.controllers import get_controller

    get = get_filter if section == "filters" else get_controller  # one registry: the pendulum's and any plant's
    for name in REGISTRY.catalog()[section][1]:
        (d,) = [x for x in describe(name) if x["section"] == section]
        decl = get(name).declaration()
        assert [p["name"] for p in d["params"]] == decl.names()
        for p in d["params"]:
            q = decl[p["name"]]
            assert p["default"] == q.default or (isinstance(q.default, float) and math.isnan(q.default))
            assert p["bounds"] == (None if q.bounds is None else (float(q.bounds[0]), float(q.bounds[1])))
            assert p["unit"] == q.unit and p["eq"] == q.eq


def _keywords(cls):
    """``{name: default}`` of every keyword-only argument of the constructors along the class's MRO."""
    import inspect

    out = {}
    for klass in cls.__mro__:
        if "__init__" in klass.__dict__:
            for p in inspect.signature(klass.__init__).parameters.values():
                if p.kind is p.KEYWORD_ONLY and p.name not in out:
                    out[p.name] = p.default
    return out


def test_optimizer_options_are_the_declaration_and_the_constructor_keywords():
    from tuner.optimizers.pso import PRESETS

    for name, cls in OPTIMIZERS.items():
        (d,) = describe(name)
        assert [p["name"] for p in d["params"]] == cls.option_names() == cls.options.names()
        decl = cls.options
        if name != "auto":  # auto takes the common options as **common
            assert set(_keywords(cls)) == set(decl.names()), name
        for key, default in _keywords(cls).items():
            declared = decl[key].default
            if default is None and name == "pso" and key in PRESETS["paper"]:
                assert declared == PRESETS["paper"][key], key   # unset: the preset's; paper's is shown
            elif key == "population":
                assert declared in (default, None), (name, key)  # None: the method derives it (population_for)
            else:
                assert declared == default, (name, key)
    pso = {p["name"]: p for p in describe("pso")[0]["params"]}
    assert pso["c2"]["default"] == 1.5 and "social" in pso["c2"]["doc"]   # thesis section 2.4 defaults
    assert pso["inertia"]["allowed"] == ["constant", "linear"] and pso["v_max"]["allowed"] == "in (0, 1]"


def test_unknown_name_lists_close_matches(capsys):
    with pytest.raises(UnknownName, match="did you mean ekf"):
        describe("ekff")
    assert main(["describe", "madgwik"]) == 2
    assert "madgwick" in capsys.readouterr().err


def test_json_is_strict_and_reads_back(capsys):
    assert main(["describe", "faekf", "--json"]) == 0
    out = capsys.readouterr().out
    import json

    json.loads(out, parse_constant=lambda c: pytest.fail(f"non-strict JSON constant {c}"))
    doc = json_load(out)
    params = {p["name"]: p for p in doc["found"][0]["params"]}
    assert params["acc_gate"]["default"] == math.inf   # inf survives as "inf" + nonfinite_paths
    assert params["q_q"]["scale"] == "log" and params["q_q"]["bounds"][0] > 0


def test_text_output_has_bounds_units_and_equation(capsys):
    assert main(["describe", "ekf"]) == 0
    out = capsys.readouterr().out
    assert "q_q" in out and "[1e-09, 0.001]" in out and "1 per sample" in out and "eq. 36" in out


def test_list_metrics_and_data(capsys):
    from objectives.attitude.objective import METRICS

    assert main(["list", "metrics"]) == 0
    out = capsys.readouterr().out
    assert all(m in out for m in METRICS) and "mae_weighted_cost" in out and "filters" not in out
    assert main(["list", "data"]) == 0
    out = capsys.readouterr().out
    assert all(s in out for s in ("broad", "csv", "bench6dof", "tilt1d", "thesis_2s"))
    assert main(["list"]) == 0
    out = capsys.readouterr().out
    assert "metrics (objective.kind: filter)" in out and "data (objective.kind: filter)" in out


def test_data_source_keys_are_what_the_loader_accepts():
    from objectives.attitude.data.cache import synthetic

    keys = {p["name"] for p in describe("tilt1d")[0]["params"]}
    assert {"duration_s", "rate_hz", "seed", "gyr_noise"} <= keys
    rec = synthetic("tilt1d", duration_s=0.5, rate_hz=100.0, seed=1, disk_cache=False)
    assert rec.gyr.shape == (50, 3)


def test_generator_keys_are_read_from_the_generators_docstrings():
    from objectives.attitude.catalog import _doc_params as doc_params

    doc = """Summary.

    Parameters
    ----------
    a, b : float
        Shared text,
        on two lines.
    c
        No type.
    **extra
        Left out.

    Returns
    -------
    x : int
        Not a parameter.
    """
    assert doc_params(doc) == {"a": "Shared text, on two lines.", "b": "Shared text, on two lines.", "c": "No type."}
    seed = {p["name"]: p for p in describe("bench6dof")[0]["params"]}["seed"]
    assert "SeedSequence" in seed["doc"] and seed["default"] == 0


def test_distribution_is_attitude_tuner_and_registers_the_kinds():
    """`tuner` and `objectives` are taken on PyPI by unrelated projects: the distribution has its own name."""
    from importlib.metadata import distribution

    dist = distribution("attitude-tuner")
    eps = {ep.name: ep.value for ep in dist.entry_points if ep.group == "tuner.objectives"}
    assert eps["filter"] == "objectives.attitude.objective:FilterObjective"
    assert {ep.name for ep in dist.entry_points if ep.group == "console_scripts"} == {"tuner"}
    assert all(src.startswith("attitude-tuner ") for k, src in REGISTRY.kinds().items() if k != "python")
