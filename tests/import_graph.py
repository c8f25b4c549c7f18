"""The import graph of a package from its sources (``ast``), for the import-circle tests.

Every ``import`` and ``from ... import`` counts, also inside functions (a function-level import is a circle that
only waits for its first call), but not under ``if TYPE_CHECKING:``. ``from pkg import name`` is an edge to the
submodule ``pkg.name`` when there is one, else to the package face ``pkg`` (``pkg/__init__.py``): importing a
name from a face that imports the importer back is the circle this finds. ``import a.b.c`` and ``from a.b.c import
x`` also pass through the faces ``a`` and ``a.b``: edges to them, except to the importer's own parent packages,
which Python runs first anyway (every package face that re-exports its submodules would otherwise be one).
"""

from __future__ import annotations

import ast
from pathlib import Path

__all__ = ["import_edges", "import_circles"]


def _modules(root: Path, package: str) -> dict[str, Path]:
    out = {}
    for path in sorted(root.rglob("*.py")):
        parts = list(path.relative_to(root).with_suffix("").parts)
        if parts[-1] == "__init__":
            parts = parts[:-1]
        out[".".join([package, *parts])] = path
    return out


def _type_checking(node: ast.If) -> bool:
    t = node.test
    return (isinstance(t, ast.Name) and t.id == "TYPE_CHECKING") or (
        isinstance(t, ast.Attribute) and t.attr == "TYPE_CHECKING")


def _imports(tree: ast.AST):
    stack = [tree]
    while stack:
        node = stack.pop()
        for child in ast.iter_child_nodes(node):
            if isinstance(child, ast.If) and _type_checking(child):
                stack.extend(child.orelse)
                continue
            if isinstance(child, (ast.Import, ast.ImportFrom)):
                yield child
            stack.append(child)


def import_edges(root: Path, package: str) -> dict[str, set[str]]:
    """``module -> modules it imports`` among the modules of ``package`` (its sources under ``root``)."""
    mods = _modules(Path(root), package)
    edges: dict[str, set[str]] = {m: set() for m in mods}
    for mod, path in mods.items():
        is_pkg = path.name == "__init__.py"
        for node in _imports(ast.parse(path.read_text(), str(path))):
            if isinstance(node, ast.Import):
                targets = [a.name for a in node.names]
            else:
                base = node.module or ""
                if node.level:
                    anchor = mod.split(".") if is_pkg else mod.split(".")[:-1]
                    anchor = anchor[:len(anchor) - node.level + 1]
                    base = ".".join(anchor + ([base] if base else []))
                targets = [f"{base}.{a.name}" if f"{base}.{a.name}" in mods else base for a in node.names]
            for t in targets:
                while t and t not in mods:  # `import a.b.c` of a name inside a module: the module
                    t = t.rpartition(".")[0]
                if t and t != mod:
                    edges[mod].add(t)
                parts = t.split(".")  # the faces a dotted import passes through on the way (Python runs them)
                for face in (".".join(parts[:i]) for i in range(1, len(parts))):
                    if face in mods and face != mod and not mod.startswith(face + "."):
                        edges[mod].add(face)
    return edges


def import_circles(edges: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components of more than one module (Tarjan), each sorted; [] when none."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    on: set[str] = set()
    stack: list[str] = []
    out: list[list[str]] = []
    counter = [0]

    def visit(v: str) -> None:
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in sorted(edges.get(v, ())):
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

    for v in sorted(edges):
        if v not in index:
            visit(v)
    return sorted(out)
