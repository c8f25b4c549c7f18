"""Filter units (a package per family: class and declaration, kernel and layouts, C port, population kernel).

- Every filter of the registry with a C port compiles and equals its numba kernel (the independent reference: the
  model the tuning scores) within 1e-9 rad at every sample, at its defaults and (slow) at every value of each of
  its declared options; the cases come from the registry and the declarations, not from a hand list.
- ``PFX_params`` is the filter's declaration (less what the port leaves out, plus what it derives): no second
  parameter list.
- A toy filter defined in this test folder only (``tests/attitude/toy_filter/``) and registered here is picked up
  by the objective, the C export, the C-against-kernel check and the population batch.
- The capabilities never name a filter (``cexport/``, ``batch.py``), each C helper is written once, and the domain
  has no import circle.
"""

from __future__ import annotations

import re
from importlib import resources
from pathlib import Path

import numpy as np
import pytest
from numba import njit

from objectives.attitude.cexport import c_filter_names, c_port, render_c_filter
from objectives.attitude.cexport.build import CFilter, compile_shared, find_compiler
from objectives.attitude.cexport.port import SHARED_PARTS, RenderContext, choice_enum
from objectives.attitude.data.bench6dof import bench6dof
from objectives.attitude.data.tilt1d import tilt1d
from objectives.attitude.filters import FILTERS, get_filter, register_filter
from objectives.attitude.filters.base import own
from objectives.attitude.filters.layout import Layout
from objectives.attitude.filters.registry import unregister_filter
from tests.attitude.cexport_cases import angle, run_c
from tests.import_graph import import_circles, import_edges
from tests.serial import serial_outcomes

needs_cc = pytest.mark.skipif(find_compiler() is None, reason="no C compiler (cc, gcc or clang) on the PATH")
TOL_RAD = 1e-9
ROOT = Path(__file__).resolve().parents[2]
TOY = "tests.attitude.toy_filter:Toy"
_BUILDS = iter(range(10**6))  # a new directory per build: the loader keeps a library by its path


@pytest.fixture(scope="module")
def benches():
    """The 6-DOF bench (NED, with external accelerations and magnetic perturbations) and the tilt bench (ENU)."""
    return {False: bench6dof(20.0, 200.0, 5, ext_acc_max_g=0.5, mag_pert_range=(0.1, 0.5)),
            True: tilt1d(20.0, 400.0, 3, frame="ENU")}


def c_equals_kernel(flt, benches, tmp_path) -> float:
    """The largest angle (rad) between the compiled C of ``flt`` and its kernel on the bench of its kind: a 3-D
    filter from the first truth sample (``init: given``), a tilt filter from the first accelerometer sample."""
    port = c_port(flt)
    rec = benches[port.tilt]
    if port.tilt:
        ref = flt.run(rec)
        files = render_c_filter(flt, rate_hz=1.0 / rec.dt, prefix="U", frame=rec.frame)
        q = CFilter(compile_shared(files, tmp_path / f"u{next(_BUILDS)}"), "U").run(rec.gyr, rec.acc, rec.mag, rec.dt)
    else:
        flt = type(flt)(**{**flt.values, "init": "truth"})
        ref = flt.run(rec)
        files = render_c_filter(flt, rate_hz=1.0 / rec.dt, init="given", prefix="U")
        c = CFilter(compile_shared(files, tmp_path / f"u{next(_BUILDS)}"), "U")
        q = run_c(c, flt, rec, rec.quat[0])
    return float(angle(ref, q).max())


def _variants(cls) -> list[dict]:
    """Each declared option (a bool or a choice) at each of its other values, the rest at the defaults."""
    out = []
    for p in cls.decl.params:
        if p.name == "init" or not (p.choices or isinstance(p.default, bool)):
            continue
        for value in (p.choices or (True, False)):
            if value != p.default:
                out.append({p.name: value})
    return out


@needs_cc
@pytest.mark.parametrize("name", c_filter_names())
def test_every_c_port_equals_its_kernel(name, benches, tmp_path):
    e = c_equals_kernel(get_filter(name)(), benches, tmp_path)
    assert e < TOL_RAD, (name, e)


@needs_cc
@pytest.mark.slow
@pytest.mark.parametrize("name", c_filter_names())
def test_every_c_port_equals_its_kernel_at_each_option(name, benches, tmp_path):
    cls = get_filter(name)
    variants = _variants(cls)
    for v in variants:
        e = c_equals_kernel(cls(**v), benches, tmp_path)
        assert e < TOL_RAD, (name, v, e)


@pytest.mark.parametrize("name", c_filter_names())
def test_the_c_params_are_the_declaration(name):
    """``PFX_params``: the sample time, every declared parameter but ``init`` and the port's ``skip`` (a choice as
    an ``int`` with its enum), the port's own fields, the start; nothing typed a second time."""
    flt = get_filter(name)()
    port = c_port(flt)
    header = render_c_filter(flt, rate_hz=100.0, prefix="P")["p.h"]
    struct = header[header.index("typedef struct {"):header.index("} P_params;")]
    members = re.findall(r"^\s+(?:P_real|int) (\w+)", struct, re.MULTILINE)
    decl = port.declaration(flt)
    declared = [p.name for p in decl.params if p.name not in ("init", *port.skip)]
    ctx = RenderContext(100.0, 0.01, 9.80665, "ENU", "double")
    own_fields = [f.name for f in (port.fields(port.param_values(flt), ctx) if port.fields else [])]
    assert members == ["dt_s", *declared, *own_fields, "init", "q0"]
    for p in decl.params:
        if p.choices and not isinstance(p.default, bool) and p.name not in ("init", *port.skip):
            for enum, i in choice_enum(p.name, p.choices):
                assert f"P_{enum} = {i}" in header


def test_a_declared_value_without_a_c_type_is_an_error_naming_it():
    from objectives.attitude.cexport.port import decl_fields
    from objectives.params import Param, ParamSet

    decl = ParamSet("x", (Param("gain", 1.0), Param("table", None, kind="any", nullable=True)))
    assert [f.name for f in decl_fields(decl, {"gain": 2.0, "table": None}, skip=("table",))] == ["gain"]
    with pytest.raises(ValueError, match="parameter 'table' .* has no C type; the port leaves it out"):
        decl_fields(decl, {"gain": 2.0, "table": None})


def test_filters_of_a_family_without_a_c_port_say_so():
    """A subclass does not inherit its parent's port (the FAEKF's kernel is not the EKF's)."""
    assert own(get_filter("ekf"), "c_port") is not None and own(get_filter("faekf"), "c_port") is None
    with pytest.raises(ValueError, match="no C port of filter 'faekf'; available: .*'ekf'"):
        render_c_filter(get_filter("faekf")(), rate_hz=100.0)


# --- a unit from the test suite --------------------------------------------------------------------------------
@pytest.fixture
def toy():
    register_filter("toy", TOY)
    try:
        yield get_filter("toy")
    finally:
        unregister_filter("toy")


@needs_cc
def test_a_toy_unit_registered_from_the_tests_is_exported_and_checked_like_the_others(toy, benches, tmp_path):
    assert "toy" in c_filter_names()  # what test_every_c_port_equals_its_kernel iterates
    for values in ({}, *_variants(toy), {"gain": 4.0, "step": "half"}):
        e = c_equals_kernel(toy(**values), benches, tmp_path)
        assert e < TOL_RAD, (values, e)
    header = render_c_filter(toy(step="half"), rate_hz=200.0, prefix="TOY")["toy.h"]
    assert "TOY_STEP_HALF = 1" in header and "TOY_real q[4];" in header  # the choice's enum, X.LEN
    assert "P_gain" not in header and "TOY_real gain;" in header


@pytest.mark.slow  # the toy's population kernel compiles in every run (uncached outside the package): 20-30 s
def test_a_toy_unit_registered_from_the_tests_runs_in_the_objective_and_the_population_batch(toy):
    from objectives.attitude.batch import batchable
    from objectives.attitude.objective import FilterObjective

    bench = {"synthetic": {"generator": "bench6dof", "duration_s": 3, "seed": 1}}
    obj = FilterObjective.from_config({"kind": "filter", "filter": "toy", "data": [bench]})
    assert batchable(obj)
    params = obj.default_space().decode_batch(np.random.default_rng(0).random((5, obj.default_space().dim)))
    params.append({"gain": -1.0})  # refused by the declaration: a failure, in the batch as serially
    serial = serial_outcomes(obj, params)
    got = obj.evaluate_batch(params, 2)
    assert [type(g) for g in got] == [type(s) for s in serial]
    assert got[:-1] == serial[:-1] and str(got[-1]) == str(serial[-1])
    assert len({g.fitness for g in got[:-1]}) == 5  # the candidates differ: the kernel ran per candidate


def test_the_registry_refuses_a_name_twice_naming_both():
    with pytest.raises(ValueError, match="'madgwick' is registered already .*madgwick:Madgwick.*not registering x:Y"):
        register_filter("madgwick", "x:Y")
    with pytest.raises(ValueError, match="module:Class"):
        register_filter("toy2", "no_colon")
    assert "toy2" not in FILTERS


# --- layouts --------------------------------------------------------------------------------------------------
def test_a_layout_gives_offsets_lengths_and_arrays():
    lay = Layout("K", (("DT", 1, "s"), ("LP", 5), ("GAIN", 1)))
    assert (lay.DT, lay.LP, lay.GAIN, lay.LEN) == (0, 1, 6, 7)
    assert lay.pack(DT=0.01, LP=[1, 2, 3, 4, 5], GAIN=2.0).tolist() == [0.01, 1, 2, 3, 4, 5, 2.0]
    tail = Layout("T", (("A", 2), ("B", 1)), start=8)
    assert (tail.A, tail.B, tail.LEN) == (8, 10, 11) and tail.pack(A=(1, 2), B=3).tolist() == [1, 2, 3]
    with pytest.raises(ValueError, match=r"missing \['GAIN'\], unknown \['X'\]"):
        lay.pack(DT=1.0, LP=np.zeros(5), X=1.0)
    with pytest.raises(ValueError, match="LP takes 5 values"):
        lay.pack(DT=1.0, LP=np.zeros(4), GAIN=1.0)
    with pytest.raises(ValueError, match="declared twice"):
        Layout("D", (("A", 1), ("A", 2)))
    with pytest.raises(ValueError, match="positive int size"):
        Layout("D", (("A", 0),))


def test_numba_reads_a_layout_as_constants():
    lay = Layout("K", (("A", 2), ("B", 1)))

    @njit
    def third(c):
        return c[lay.B] + lay.LEN

    assert third(np.array([1.0, 2.0, 40.0])) == 43.0


# --- the capabilities' machinery -------------------------------------------------------------------------------
def _filter_names() -> set[str]:
    names = set(FILTERS) | {cls.rsplit(":", 1)[1] for cls in FILTERS.values()}
    return {n.lower() for n in names} | {"complementary", "kalman"}


def test_cexport_and_the_batch_name_no_filter():
    """The C renderer, its hooks, its shared parts and the population lanes are machinery: what a filter brings, its
    unit declares (``c_port``, ``population``)."""
    files = [*sorted((ROOT / "objectives/attitude/cexport").rglob("*.*")), ROOT / "objectives/attitude/batch.py"]
    found = {}
    for path in files:
        if path.suffix not in (".py", ".c", ".h"):
            continue
        text = path.read_text().lower()
        hits = sorted(n for n in _filter_names() if re.search(rf"(?<![a-z0-9]){n}(?![a-z0-9])", text))
        if hits:
            found[str(path.relative_to(ROOT))] = hits
    assert not found, found


def test_each_c_helper_is_defined_once_over_the_shared_parts_and_the_ports(toy):
    """A helper two ports need lives in one shared part, not in a copy per port; the source of every port (its
    shared parts and its own file) defines the streaming API once."""
    where: dict[str, set[str]] = {}
    shared = {p: resources.files("objectives.attitude.cexport").joinpath("templates", p).read_text()
              for p in ("common.c", *SHARED_PARTS, "run.c")}
    ports = {}
    for name in c_filter_names():
        port = c_port(get_filter(name)())
        ports[port.source] = (port, resources.files(port.source[0]).joinpath(port.source[1]).read_text())
    sources = {**shared, **{f"{pkg}/{f}": text for (pkg, f), (_, text) in ports.items()}}
    for src, text in sources.items():
        defs = re.sub(r"^\w[^\n]*\);[ \t]*$", "", text, flags=re.MULTILINE)  # a prototype defines nothing
        for fn in re.findall(r"^(?:static )?(?:inline )?\w+ \**(\w+)\(", defs, re.MULTILINE):
            where.setdefault(fn, set()).add(src)
    # a function a shared part declares and calls is each port's own (as the PFX_ API is)
    hooks = {fn for text in shared.values()
             for fn in re.findall(r"^(?:static )?\w+ \**(\w+)\([^\n]*\);[ \t]*$", text, re.MULTILINE)}
    twice = {fn: sorted(s) for fn, s in where.items() if len(s) > 1 and not fn.startswith("PFX_")
             and fn != "set_rate" and fn not in hooks}
    assert not twice, twice
    assert {"robust_init", "robust_rate", "floor_", "sincos_", "qmul", "start_quaternion"} <= set(where)
    for src, (port, text) in ports.items():
        whole = "\n".join([*(shared[p] for p in ("common.c", *port.parts)), text])
        for api in ("init", "update", "quaternion", "set_quaternion", "gyro_bias"):
            assert len(re.findall(rf"^void PFX_{api}\(", whole, re.MULTILINE)) == 1, (src, api)


def test_the_domain_has_no_import_circle():
    """Counting imports inside functions and imports of a package face (``from pkg import name``)."""
    assert import_circles(import_edges(ROOT / "objectives", "objectives")) == []


def test_the_circle_check_finds_a_circle_through_a_package_face(tmp_path):
    pkg = tmp_path / "pkg"
    (pkg / "sub").mkdir(parents=True)
    (pkg / "__init__.py").write_text("")
    (pkg / "sub" / "__init__.py").write_text("from pkg.sub.base import Base\n\ndef get():\n    return Base\n")
    (pkg / "sub" / "base.py").write_text("class Base:\n    def f(self):\n        from pkg.sub import get\n")
    (pkg / "other.py").write_text("from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n    from pkg.sub import get\n")
    assert import_circles(import_edges(pkg, "pkg")) == [["pkg.sub", "pkg.sub.base"]]


def test_the_circle_check_counts_the_faces_a_dotted_import_passes_through(tmp_path):
    pkg = tmp_path / "pkg"
    (pkg / "sub").mkdir(parents=True)
    (pkg / "__init__.py").write_text("")
    (pkg / "a.py").write_text("from pkg.sub.x import y\n")  # runs pkg/sub/__init__.py first
    (pkg / "sub" / "__init__.py").write_text("def f():\n    from pkg import a\n")
    (pkg / "sub" / "x.py").write_text("import pkg.sub.y\ny = 1\n")  # its own parent package: no edge to it
    (pkg / "sub" / "y.py").write_text("")
    assert import_circles(import_edges(pkg, "pkg")) == [["pkg.a", "pkg.sub"]]
