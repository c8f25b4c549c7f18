"""The report's plot list (tuner.plots): a plot is one module, drawn as a PNG and, from the same data, in its
interactive slot; a plot registered from here appears in both pages; ``tuner_report.js`` draws every slot a
report, a sweep report and a dashboard hold (run under node with a stand-in for the page and for plotly)."""

import json
import re
import shutil
import subprocess
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from tests.conftest import run_tuner
from tuner import interactive, plots
from tuner.config import config_from_dict
from tuner.figures import new_figure
from tuner.report import write_run_report
from tuner.run import run

JS = Path(__file__).resolve().parents[2] / "tuner" / "static" / "tuner_report.js"
needs_plotly = pytest.mark.skipif(not interactive.available(), reason="plotly not installed (the report extra)")


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("plots")
    raw = {"name": "p", "seed": 2, "objective": {"kind": "function", "function": "rosenbrock", "dim": 3},
           "optimizer": {"method": "pso", "population": 10, "generations": 4}, "parallel": {"backend": "serial"}}
    return run(config_from_dict(raw, base_dir=tmp), run_dir=tmp / "run", quiet=True).run_dir


def _page_data(page: str) -> dict:
    return json.loads(re.search(r'<script type="application/json" id="tuner-data">(.*?)</script>', page, re.S).group(1))


# --- a toy plot: what adding a plot takes ---------------------------------------------------------------
def _toy(slot: bool):
    """The mean fitness of each generation: a data function and its two renderers."""

    def data(ctx):
        ok = ctx.ok
        means = ok.groupby("generation")["fitness"].mean()
        return {"generation": means.index.astype(int).tolist(), "mean": means.tolist()}

    def figure(d):
        fig = new_figure(2.0)
        fig.subplots().plot(d["generation"], d["mean"])
        return fig

    return SimpleNamespace(NAME="toy", FILE="toy_means.png", data=data, title=lambda d: "Mean fitness per generation",
                           caption=lambda d: f"{len(d['mean'])} generations.", figure=figure,
                           slot=(lambda d: {"x": d["generation"], "y": d["mean"]}) if slot else (lambda d: None))


@pytest.fixture
def run_plots():
    """The run report's plot list, restored after the test."""
    saved = list(plots.RUN_PLOTS)
    yield plots.RUN_PLOTS
    plots.RUN_PLOTS[:] = saved


@pytest.mark.parametrize("with_slot", [False, True])
@pytest.mark.slow
def test_a_plot_registered_from_outside_is_drawn_in_both_pages(run_dir, tmp_path, run_plots, with_slot):
    d = Path(shutil.copytree(run_dir, tmp_path / "run"))
    plots.register(_toy(with_slot))
    assert run_plots[-1].NAME == "toy"
    write_run_report(d)
    md = (d / "report.md").read_text()
    title = "Mean fitness per generation"
    assert f"### {title}\n\n4 generations.\n\n![{title}](figures/toy_means.png)" in md
    assert (d / "figures" / "toy_means.png").read_bytes()[:4] == b"\x89PNG"
    page = (d / "report.html").read_text()
    if interactive.available():
        data = _page_data(page)
        assert ('data-plot="toy"' in page) == with_slot and ("toy" in data) == with_slot
        if with_slot:
            hist = __import__("pandas").read_csv(d / "history.csv")
            assert data["toy"]["y"] == hist.groupby("generation")["fitness"].mean().tolist()
        else:  # no interactive renderer: the page shows the PNG, as the static page does
            assert page.count("<img") == md.count("](figures/") - len(re.findall(r'data-plot="', page))
    # the plot is not an objective figure: the figures section lists it once
    assert md.count("toy_means.png") == 1


def test_a_plot_is_refused_without_its_whole_face_or_with_a_taken_name():
    with pytest.raises(ValueError, match="plot 'toy': missing slot"):
        plots.register(SimpleNamespace(**{k: v for k, v in vars(_toy(True)).items() if k != "slot"}), [])
    with pytest.raises(ValueError, match="plot 'convergence' .* the name or file of 'convergence'"):
        plots.register(SimpleNamespace(**{**vars(_toy(True)), "NAME": "convergence"}), list(plots.RUN_PLOTS))


# --- tuner_report.js draws every slot ---------------------------------------------------------------------
HARNESS = r"""
const fs = require('fs');
const js = fs.readFileSync(process.argv[2], 'utf8'), data = fs.readFileSync(process.argv[3], 'utf8');
const names = JSON.parse(process.argv[4]);
const calls = [], errors = [];
function elem(tag) {
  return {tag: tag, attrs: {}, children: [], style: {}, rows: [], tBodies: [], options: [], value: '', parent: null,
          classList: {add: function () {}},
          setAttribute: function (k, v) { this.attrs[k] = String(v); },
          getAttribute: function (k) { return k in this.attrs ? this.attrs[k] : null; },
          appendChild: function (c) { c.parent = this; this.children.push(c); return c; },
          addEventListener: function () {}, querySelectorAll: function () { return []; },
          querySelector: function () { return null; }, textContent: ''};
}
const divs = names.map(function (n) { const d = elem('div'); d.attrs['data-plot'] = n; return d; });
global.document = {readyState: 'complete', addEventListener: function () {}, createElement: elem,
  getElementById: function (id) { return id === 'tuner-data' ? {textContent: data} : null; },
  querySelectorAll: function (sel) { return sel.indexOf('div.tuner-plot') === 0 ? divs : []; }};
global.window = {location: {hash: ''},
                 sessionStorage: {getItem: function () { return null; }, setItem: function () {}}};
console.error = function () { errors.push([].join.call(arguments, ' ')); };
function owner(div) { while (div.parent) { div = div.parent; } return div.attrs['data-plot'] || '?'; }
function points(t) {
  const ys = t.type === 'contour' ? [].concat.apply([], t.z) : (t.y || t.x || []);
  return ys.filter(function (v) { return v !== null && v !== undefined; }).length;
}
global.Plotly = {newPlot: function (div, traces) {
  calls.push({plot: owner(div), traces: traces.length, points: traces.map(points)}); return Promise.resolve(); }};
Plotly.react = Plotly.newPlot;
eval(js);
setTimeout(function () {
  console.log(JSON.stringify({errors: errors, calls: calls,
    rendered: divs.map(function (d) { return [d.attrs['data-plot'], d.attrs['data-rendered'] === '1']; })}));
}, 100);
"""


def _draw(page: Path, tmp_path: Path, damage=None) -> dict:
    """What ``tuner_report.js`` draws from ``page``'s data: per slot, its plotly calls and whether it is marked
    drawn, and the console errors."""
    node = shutil.which("node")
    if node is None:
        pytest.skip("node not installed")
    text = page.read_text()
    data = _page_data(text)
    if damage:
        damage(data)
    names = re.findall(r'data-plot="([a-z_-]+)"', text)
    (tmp_path / "harness.js").write_text(HARNESS)
    (tmp_path / "data.json").write_text(json.dumps(data))
    out = subprocess.run([node, str(tmp_path / "harness.js"), str(JS), str(tmp_path / "data.json"), json.dumps(names)],
                         capture_output=True, text=True, timeout=60)
    assert out.returncode == 0, out.stderr
    res = json.loads(out.stdout)
    res["names"] = names
    return res


@needs_plotly
def test_the_script_draws_every_slot_of_a_run_report(run_dir, tmp_path):
    res = _draw(run_dir / "report.html", tmp_path)
    assert res["names"] == ["convergence", "importance", "slices", "parcoords", "contour"]
    assert res["errors"] == [] and all(done for _, done in res["rendered"]), res
    by_plot = {n: [c for c in res["calls"] if c["plot"] == n] for n in res["names"]}
    assert all(by_plot[n] and all(sum(c["points"]) > 0 for c in by_plot[n]) for n in res["names"]), by_plot
    assert len(by_plot["slices"]) == 3  # one panel per searched parameter
    data = _page_data((run_dir / "report.html").read_text())
    pc = by_plot["parcoords"][0]  # five rank bands at most, and the best: the PNG's candidates
    assert pc["traces"] <= 6 and pc["points"][-1] == 3 and len(data["parcoords"]["u"]) == 20


@needs_plotly
def test_the_script_reports_a_slot_without_data_and_draws_nothing_of_an_emptied_one(run_dir, tmp_path):
    res = _draw(run_dir / "report.html", tmp_path, damage=lambda d: d.pop("contour"))
    assert res["errors"] == ["tuner: plot contour: no data"] and ["contour", False] in res["rendered"]

    def empty(d):
        d["convergence"]["best"], d["convergence"]["gen_median"] = [], []

    res = _draw(run_dir / "report.html", tmp_path, damage=empty)
    assert [sum(c["points"]) for c in res["calls"] if c["plot"] == "convergence"] == [0]


@needs_plotly
@pytest.mark.slow
def test_the_script_draws_a_sweep_and_a_dashboard(tmp_path):
    base = {"name": "s", "seed": 1, "objective": {"kind": "function", "function": "sphere", "dim": 2},
            "optimizer": {"method": "pso", "population": 4, "generations": 2}, "parallel": {"backend": "serial"}}
    doc = {"sweep": {"name": "two", "base": base, "variants": {"pso": {}, "de": {"optimizer.method": "de"}},
                     "seeds": [1]}}
    (tmp_path / "sweep.yaml").write_text(json.dumps(doc))
    root = tmp_path / "runs"
    assert run_tuner("sweep", tmp_path / "sweep.yaml", "--dir", root / "sw", "-q").returncode == 0
    res = _draw(root / "sw" / "report.html", tmp_path)
    assert res["names"] == ["convergence"] and res["errors"] == [] and res["rendered"] == [["convergence", True]]
    assert res["calls"][0]["traces"] == 2 and min(res["calls"][0]["points"]) > 0  # one line per job
    assert run_tuner("dashboard", root).returncode == 0
    res = _draw(root / "index.html", tmp_path)
    assert res["names"] == ["dashboard"] and res["errors"] == [] and res["rendered"] == [["dashboard", True]]
    data = _page_data((root / "index.html").read_text())["dashboard"]
    assert len(data["runs"]) == 3 and isinstance(data["log"], bool)
    assert np.isfinite([r["best"] for r in data["runs"] if r["kind"] == "job"]).all()


@needs_plotly
@pytest.mark.slow
def test_the_script_draws_the_score_against_a_swept_value(tmp_path):
    """A sweep over a number (three values, two seeds): the interactive page draws its swept slot, one marker
    trace and one median line per series, every job a point."""
    base = {"name": "s", "seed": 1, "objective": {"kind": "function", "function": "sphere", "dim": 2},
            "optimizer": {"method": "pso", "population": 4, "generations": 2}, "parallel": {"backend": "serial"}}
    doc = {"sweep": {"name": "grid", "base": base, "grid": {"optimizer.generations": [1, 2, 3]}, "seeds": [1, 2]}}
    (tmp_path / "sweep.yaml").write_text(json.dumps(doc))
    assert run_tuner("sweep", tmp_path / "sweep.yaml", "--dir", tmp_path / "sw", "-q").returncode == 0
    res = _draw(tmp_path / "sw" / "report.html", tmp_path)
    assert "swept" in res["names"] and res["errors"] == [] and ["swept", True] in res["rendered"]
    call = next(c for c in res["calls"] if c["plot"] == "swept")
    assert call["traces"] == 2 and call["points"] == [6, 3]  # every job, then the three medians
    data = _page_data((tmp_path / "sw" / "report.html").read_text())["swept"]
    assert data["key"] == "optimizer.generations" and data["series"][0]["mx"] == [1.0, 2.0, 3.0]
