"""The closed-loop figures draw on their own Figure: the caller's matplotlib backend and rcParams stay as set.

A notebook that tunes a controller keeps its inline backend and its style (STYLE 19); before, the figures
called ``matplotlib.use("Agg")`` and rewrote font sizes in ``rcParams``.
"""

import matplotlib
import pytest

from objectives.control.objective import ClosedLoopObjective
from objectives.control.plants.report import write_report
from objectives.control.plants.wmp.report import plot_response, plot_surfaces


@pytest.fixture
def svg_backend():
    """The process on the svg backend with a font size of its own, restored afterwards."""
    old_backend, old_rc = matplotlib.get_backend(), matplotlib.rcParams.copy()
    matplotlib.use("svg")
    matplotlib.rcParams["font.size"] = 7.0
    yield matplotlib.rcParams.copy()
    matplotlib.rcParams.update(old_rc)
    matplotlib.use(old_backend)


def _untouched(before):
    assert matplotlib.get_backend() == "svg"
    assert dict(matplotlib.rcParams) == dict(before)


def test_pendulum_figures_leave_backend_and_rcparams(tmp_path, svg_backend):
    obj = ClosedLoopObjective(controller="protective_fuzzy", duration_s=1.0)
    path = plot_response(obj.loop, obj.defaults, None, tmp_path / "response.png")
    assert path.read_bytes()[:4] == b"\x89PNG"
    (surf, *_) = plot_surfaces(obj.loop.ctrl, obj.defaults, obj.defaults, tmp_path)
    assert surf.read_bytes()[:4] == b"\x89PNG"
    _untouched(svg_backend)


@pytest.mark.slow
def test_loop_report_leaves_backend_and_rcparams(tmp_path, svg_backend):
    obj = ClosedLoopObjective.from_config({"plant": {"tf": {"num": [2.0], "den": [0.5, 1.0]}}, "controller": "pid2dof",
                                           "scenario": {"duration_s": 2.0, "reference": [{"t": 0.1, "value": 1.0}]},
                                           "requirements": {"max_ms": 2.0}})
    out = write_report(obj.loop, tmp_path, obj.defaults, obj.defaults)
    assert out["best_fitness"] == obj(obj.defaults).fitness
    for name in ("response.png", "bode.png"):
        assert (tmp_path / "figures" / name).read_bytes()[:4] == b"\x89PNG"
    _untouched(svg_backend)
