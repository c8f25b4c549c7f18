"""The closed loop's layout: one kind space, registries that load, no plant-attribute dispatch, no import circle."""

import ast
import pathlib

import pytest

from objectives.control import kinds
from objectives.control.controllers import CONTROLLERS, controllers_of, get_controller
from objectives.control.plants import LOOPS, PLANTS, get_plant_kind, loop_class

CONTROL = pathlib.Path(__file__).resolve().parents[2] / "objectives" / "control"


def test_one_kind_space_without_shared_numbers():
    names = [k for k in vars(kinds) if k.startswith("KIND_")]
    values = [getattr(kinds, k) for k in names]
    assert len(set(values)) == len(values) == len(kinds.KINDS)
    family = {}  # a kind is one branch of one loop's kernel (pid2dof_par runs pid2dof's, in other units)
    for name in CONTROLLERS:
        cls = get_controller(name)
        assert cls.kind in kinds.KINDS, name
        assert family.setdefault(cls.kind, cls.family) == cls.family, f"kind {cls.kind} in two loops ({name})"
    assert kinds.KIND_PID != kinds.KIND_WMP_PID  # once two constants named KIND_PID, 1 and 3


def test_every_plant_kind_and_controller_has_its_loop():
    families = {get_plant_kind(k).family for k in PLANTS}
    assert families == set(LOOPS)
    for fam in families:
        loop = loop_class(fam)
        assert loop.family == fam and get_controller(loop.DEFAULT_CONTROLLER).family == fam
    assert {get_controller(n).family for n in CONTROLLERS} <= families
    assert set(controllers_of("wmp")) == {"lqr", "lqg", "pid", "flc", "protective_fuzzy", "lut"}


@pytest.mark.parametrize("rel", ["objective.py", "plants/simulate.py", "plants/loop.py", "plants/wmp/loop.py",
                                 "plants/report.py", "deployment.py"])
def test_no_hasattr_dispatch_on_plants(rel):
    tree = ast.parse((CONTROL / rel).read_text())
    calls = [n for n in ast.walk(tree) if isinstance(n, ast.Call) and getattr(n.func, "id", "") == "hasattr"]
    assert not calls, f"{rel}: hasattr at lines {[c.lineno for c in calls]}"


def _imports():
    mods = {}
    for f in CONTROL.rglob("*.py"):
        rel = f.relative_to(CONTROL.parents[1]).with_suffix("")
        mods[".".join(rel.parts[:-1] if rel.name == "__init__" else rel.parts)] = f
    edges = {m: set() for m in mods}
    for m, f in mods.items():
        for node in ast.walk(ast.parse(f.read_text())):  # module level and inside functions alike
            if isinstance(node, ast.ImportFrom) and node.module and not node.level:
                for a in node.names:
                    sub = f"{node.module}.{a.name}"
                    target = sub if sub in mods else node.module
                    if target in mods:
                        edges[m].add(target)
            elif isinstance(node, ast.Import):
                edges[m].update(a.name for a in node.names if a.name in mods)
    return edges


def test_no_import_circle_counting_imports_inside_functions():
    edges = _imports()
    for start in edges:
        seen, stack = set(), [(start, (start,))]
        while stack:
            node, path = stack.pop()
            for nxt in edges[node]:
                assert nxt != start, "import circle: " + " -> ".join((*path, nxt))
                if nxt not in seen:
                    seen.add(nxt)
                    stack.append((nxt, (*path, nxt)))
