"""The engine's import graph has no circle: counting the imports inside functions (they run too, later) and
the package faces they pass through (``from tuner import x`` where ``x`` is a name of ``tuner/__init__.py``,
and the ``__init__.py`` of every package a dotted import enters)."""

from pathlib import Path

from tests.import_graph import import_circles, import_edges

ROOT = Path(__file__).resolve().parents[2]


def import_graph(root: Path, package: str) -> dict[str, set[str]]:
    """``{module: modules it imports}`` over ``package`` under ``root`` (:func:`tests.import_graph.import_edges`)."""
    return import_edges(root / package, package)


circles = import_circles


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
