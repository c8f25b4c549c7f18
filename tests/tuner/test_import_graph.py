"""The engine's import graph has no circle: counting the imports inside functions (they run too, later) and
the package faces they pass through (``from tuner import x`` where ``x`` is a name of ``tuner/__init__.py``,
and the ``__init__.py`` of every package a dotted import enters)."""

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def module_names(root: Path, package: str) -> dict[str, Path]:
    """``{dotted name: file}`` of every module of ``package`` under ``root`` (a package is its ``__init__``)."""
    out = {}
    for path in sorted((root / package).rglob("*.py")):
        parts = list(path.relative_to(root).with_suffix("").parts)
        if parts[-1] == "__init__":
            parts = parts[:-1]
        out[".".join(parts)] = path
    return out


def import_graph(root: Path, package: str) -> dict[str, set[str]]:
    """``{module: modules it imports}`` over ``package``, every ``import`` statement wherever it stands.

    ``import a.b.c`` and ``from a.b import c`` (``c`` a module) run ``a/__init__`` and ``a/b/__init__``: edges
    to those faces, except to the importer's own enclosing packages, which Python has run before the importer
    anyway. ``from a.b import name`` (``name`` not a module) reads the face ``a.b`` itself: an edge to it
    always, so ``tuner/run.py`` taking ``__version__`` from ``tuner/__init__.py`` counts.
    """
    mods = module_names(root, package)

    def chain(name: str) -> list[str]:
        parts = name.split(".")
        return [n for n in (".".join(parts[:i]) for i in range(1, len(parts) + 1)) if n in mods]

    graph: dict[str, set[str]] = {m: set() for m in mods}
    for m, path in mods.items():
        here = m.split(".") if path.name == "__init__.py" else m.split(".")[:-1]
        for node in ast.walk(ast.parse(path.read_text(), str(path))):
            edges: list[tuple[str, bool]] = []  # (target, only passed through on the way)
            if isinstance(node, ast.Import):
                for a in node.names:
                    c = chain(a.name)
                    edges += [(t, True) for t in c[:-1]] + [(t, False) for t in c[-1:]]
            elif isinstance(node, ast.ImportFrom):
                base = here[:len(here) - node.level + 1] if node.level else []
                mod = ".".join(base + ([node.module] if node.module else []))
                edges += [(t, True) for t in chain(mod)]
                for a in node.names:
                    sub = f"{mod}.{a.name}"
                    if sub in mods:
                        edges.append((sub, False))
                    elif mod in mods:
                        edges.append((mod, False))
            for t, passed in edges:
                if t != m and not (passed and m.startswith(t + ".")):
                    graph[m].add(t)
    return graph


def circles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components of more than one module (Tarjan), each sorted."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on: set[str] = set()
    out: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in sorted(graph[v]):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                out.append(sorted(comp))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return out


def test_the_engine_has_no_import_circle():
    assert circles(import_graph(ROOT, "tuner")) == []


def _write(root: Path, files: dict[str, str]) -> None:
    for name, text in files.items():
        (root / name).parent.mkdir(parents=True, exist_ok=True)
        (root / name).write_text(text)


def test_the_check_sees_a_circle_through_a_function_level_import_and_a_package_face(tmp_path):
    # the shape tuner had: run.py took __version__ from the face, which imported api (lazily), which imported run
    _write(tmp_path, {"pkg/__init__.py": "__version__ = '1'\n\ndef tune():\n    from pkg import api\n",
                      "pkg/api.py": "from pkg.run import run\n",
                      "pkg/run.py": "def run():\n    from pkg import __version__\n",
                      "pkg/leaf.py": "from pkg.sub import x\n",
                      "pkg/sub/__init__.py": "def f():\n    from pkg import leaf\n",
                      "pkg/sub/x.py": ""})
    found = circles(import_graph(tmp_path, "pkg"))
    assert ["pkg", "pkg.api", "pkg.run"] in found
    assert ["pkg.leaf", "pkg.sub"] in found  # leaf enters the face pkg/sub/__init__, which imports leaf
    assert len(found) == 2


def test_a_module_below_a_package_does_not_circle_with_it_by_being_inside_it(tmp_path):
    _write(tmp_path, {"pkg/__init__.py": "def f():\n    from pkg.sub import x\n",
                      "pkg/sub/__init__.py": "", "pkg/sub/x.py": "from pkg.sub import y\nimport pkg.other\n",
                      "pkg/sub/y.py": "", "pkg/other.py": ""})
    assert circles(import_graph(tmp_path, "pkg")) == []
