"""Run and sweep reports and the runs dashboard: content, hostile names neutralised, the live view, and
real headless Chromium at 1200 px and 390 px (no horizontal overflow, every image decodes, every plot
draws, sorting a table reorders it, no console or CSP error; screenshots in the test output folder).

Screenshots go to ``$TUNER_TEST_OUTPUT/browser/`` (default ``test-output/browser/`` in the repository).
"""

import json
import math
import re
import shutil
from pathlib import Path

import pytest
import yaml

from tests.conftest import built_once, run_tuner
from tests.tuner.browser import measure, needs_chromium, output_dir, screenshot
from tests.tuner.test_render import _assert_inert, _assert_inert_attrs, _parse
from tuner.config import config_from_dict
from tuner.run import run

pytestmark = pytest.mark.slow  # every test here tunes, sweeps or drives a browser

EVIL_METRIC = "<script>alert('m')</script>"
EVIL_REC = "[x](javascript:alert('r'))"
EVIL_TEXT = "<img src=x onerror=alert('d')> [y](javascript:alert('d')) <script>alert('d')</script>"


def _assert_safe(page: str) -> None:
    """A static page is inert (no script at all); an interactive one loads only its two local scripts and
    holds its data in one JSON block that no text in it can close."""
    from tuner.interactive import SCRIPTS

    if "<script" not in page:
        _assert_inert(page)
        return
    t = _parse(page)
    srcs = [v for tag, k, v in t.attrs if tag == "script" and k == "src"]
    types = [v for tag, k, v in t.attrs if tag == "script" and k == "type"]
    assert sorted(srcs) == sorted(SCRIPTS) and types == ["application/json"], (srcs, types)
    assert t.tags.count("script") == 3
    assert "script-src 'self';" in page and "unsafe-eval" not in page and "unsafe-inline'; " not in page
    block = page.split('<script type="application/json" id="tuner-data">', 1)[1].split("</script>", 1)[0]
    assert "<" not in block and ">" not in block
    json.loads(block)
    _assert_inert_attrs(t)


def _page_data(page: str) -> dict:
    return json.loads(page.split('id="tuner-data">', 1)[1].split("</script>", 1)[0])


def evil_objective(params, run_dir=None, log=None):
    """A python objective with hostile metric and recording names; every 7th candidate fails.

    With ``run_dir`` and ``log``, appends what ``report.html`` says at each evaluation to ``log`` (JSON lines).
    """
    x, y = float(params["x"]), float(params["y"])
    if run_dir is not None:  # the live view: what report.html says while the run is going
        from pathlib import Path

        page = Path(run_dir) / "report.html"
        with open(log, "a") as fh:
            fh.write(json.dumps(page.read_text() if page.exists() else None) + "\n")
    if int(y * 1000) % 7 == 0:
        return float("nan")
    f = (math.log10(x) - 2.9) ** 2 + (y - 0.5) ** 2 + 1e-9
    return f, {EVIL_METRIC: f, f"rec/{EVIL_REC}/rmse_deg": 2 * f, "rec/walk/rmse_deg": 3 * f,
               f"rec/{EVIL_REC}/{EVIL_METRIC}": 1.0, "rec/walk/" + EVIL_METRIC: 4.5e-9}


def _raw(name, options=None, generations=4):
    return {"name": name, "seed": 3, "description": EVIL_TEXT,
            "objective": {"kind": "python", "callable": "tests.tuner.test_report_browser:evil_objective",
                          "options": options or {}},
            "parameters": {"x": {"low": 1e-3, "high": 1e3, "scale": "log", "unit": "rad/s"},
                           "y": {"low": 0.0, "high": 1.0}, "mode": {"fixed": EVIL_TEXT}},
            "optimizer": {"method": "pso", "population": 8, "generations": generations},
            "parallel": {"backend": "serial"}}


@pytest.fixture(scope="module")
def evil_run(tmp_path_factory):
    def build(tmp):
        run(config_from_dict(_raw("evil"), base_dir=tmp), run_dir=tmp / "run", quiet=True)

    return built_once(tmp_path_factory, "evil", build) / "run"


def test_run_report_content(evil_run):
    md = (evil_run / "report.md").read_text()
    page = (evil_run / "report.html").read_text()
    for section in ("## Summary", "## Warnings", "## Best parameters", "## Scores per recording", "## Figures"):
        assert section in md
    assert "http-equiv=\"refresh\"" not in page and "finished" in md  # the final report does not reload
    # x ends near 10^2.9 = 794 of [1e-3, 1e3]: 1.7 % of the log range from the high bound
    best = yaml.safe_load((evil_run / "best.yaml").read_text())
    u = (math.log10(best["params"]["x"]) + 3) / 6
    assert ("x = " in md and "high bound" in md) == (1 - u <= 0.02)
    assert "evaluations failed" in md
    # the recording x metric table: rows = recordings, columns = metrics
    table = next(t.split("</table>")[0] for t in page.split("<table>")[1:] if "rmse_deg" in t.split("</table>")[0])
    heads = re.findall(r"<th[^>]*>(.*?)</th>", table.split("</thead>")[0])
    assert heads[0] == "recording" and "rmse_deg" in heads and "&lt;script&gt;alert('m')&lt;/script&gt;" in heads
    assert table.count("<tr>") == 1 + 3  # two recordings and "-" (the metric without a recording)
    assert "4.5e-09" in table
    for png in ("convergence", "fitness_vs_params", "parallel_coordinates"):
        assert (evil_run / "figures" / f"{png}.png").exists()


def test_hostile_names_are_neutralised(evil_run, tmp_path, monkeypatch):
    from tuner import interactive
    from tuner.report import write_run_report

    page = (evil_run / "report.html").read_text()
    evil_run = Path(shutil.copytree(evil_run, tmp_path / "evil"))  # the pages are rewritten below
    _assert_safe(page)
    assert "&lt;img src=x onerror=alert('d')&gt;" in page  # description and string parameter shown as text
    assert "[x](javascript:alert('r'))" in page  # recording name shown literally, not as a link
    # without plotly: today's static page, no script at all
    monkeypatch.setattr(interactive, "available", lambda: False)
    write_run_report(evil_run)
    static = (evil_run / "report.html").read_text()
    _assert_inert(static)
    assert "<img src=\"data:image/png;base64," in static and "data-plot=" not in static
    monkeypatch.undo()
    write_run_report(evil_run)  # back to the interactive page
    assert ("data-plot=" in (evil_run / "report.html").read_text()) == interactive.available()


@pytest.mark.skipif(not __import__("tuner.interactive").interactive.available(), reason="plotly not installed")
def test_interactive_run_page_holds_its_data_and_assets(evil_run):
    from tuner.interactive import SCRIPTS

    page = (evil_run / "report.html").read_text()
    data = _page_data(page)
    assert all((evil_run / s).is_file() for s in SCRIPTS)
    slots = re.findall(r'data-plot="([a-z]+)"', page)
    assert slots == ["convergence", "importance", "slices", "parcoords", "contour"]
    assert list(data) == slots  # one slot of data per plot: the data its PNG is drawn from
    params = data["slices"]["params"]
    assert [p["name"] for p in params] == ["x", "y"] and params[0]["unit"] == "rad/s"
    hist = __import__("pandas").read_csv(evil_run / "history.csv")
    ok = hist[hist["status"] == "ok"]
    points = data["slices"]["points"]
    assert len(points["fitness"]) == len(ok) and min(points["fitness"]) == ok["fitness"].min()
    # x is the parameter that matters (its log10 distance to 2.9 dominates the fitness)
    assert data["importance"]["names"][0] == "x" and sum(data["importance"]["share"]) == pytest.approx(1.0)
    assert "functional ANOVA" in page and "matters most" in page
    assert data["contour"]["xp"]["name"] == "x" and data["contour"]["xp"]["scale"] == "log"
    md = (evil_run / "report.md").read_text()
    assert "tuner-plot" not in md and "{{plot:" not in md and "![Convergence](figures/convergence.png)" in md


def test_multiline_values_stay_out_of_tables(tmp_path):
    from tuner.report import write_run_report

    src = tmp_path / "r"
    raw = {"name": "m", "seed": 1, "objective": {"kind": "function", "function": "sphere", "dim": 2},
           "optimizer": {"method": "random", "population": 4, "generations": 1}, "parallel": {"backend": "serial"}}
    d = run(config_from_dict(raw, base_dir=tmp_path), run_dir=src, quiet=True).run_dir
    best = yaml.safe_load((d / "best.yaml").read_text())
    best["evaluation"] = {"notes_table": "a | b\n--- | ---\n1 | 2", "test_fitness": 4.5e-9,
                          "per_trial": {"t1": {"agnostic": 1.0, "own": 0.5}}}
    (d / "best.yaml").write_text(yaml.safe_dump(best))
    write_run_report(d)
    page = (d / "report.html").read_text()
    assert "<pre><code>a | b\n--- | ---\n1 | 2\n</code></pre>" in page
    assert "4.5e-09" in page and "test fitness" in page


def test_live_report_reloads_while_running_and_not_after(tmp_path, monkeypatch):
    import tuner.report

    monkeypatch.setattr(tuner.report, "LIVE_MIN_INTERVAL_S", 0.0)
    d, log = tmp_path / "live", tmp_path / "seen.jsonl"
    raw = _raw("live", {"run_dir": str(d), "log": str(log)}, generations=3)
    run(config_from_dict(raw, base_dir=tmp_path), run_dir=d, quiet=True)
    seen = [json.loads(ln) for ln in log.read_text().splitlines()]
    assert len(seen) == 25 and seen[0] is None  # the preflight evaluates the defaults once before the run
    seen = seen[1:]
    # generation 1 (8 evaluations) sees no page, generations 2 and 3 the live page written after 1 and 2
    assert seen[:8] == [None] * 8 and len(seen) == 24
    live_pages = seen[8:]
    assert all('http-equiv="refresh"' in p and "Live view" in p and "running" in p for p in live_pages)
    final = (d / "report.html").read_text()
    assert 'http-equiv="refresh"' not in final and "finished" in final


def test_interrupted_run_gets_a_report_that_stops_reloading(evil_run, tmp_path):

    from tuner.report import write_live_report

    d = tmp_path / "copy"
    shutil.copytree(evil_run, d)
    meta = json.loads((d / "meta.json").read_text())
    running = {**meta, "status": "running"}
    (d / "meta.json").write_text(json.dumps(running))
    assert write_live_report(d, running, final=True) is None  # no live report yet: nothing to replace
    assert write_live_report(d, running, min_interval_s=0.0) == d / "report.md"
    assert 'http-equiv="refresh"' in (d / "report.html").read_text()
    show = run_tuner("show", str(d))
    assert show.returncode == 0 and "running" in show.stdout  # tuner show works on a running run
    stopped = {**meta, "status": "interrupted"}
    assert write_live_report(d, stopped, final=True) == d / "report.md"
    page = (d / "report.html").read_text()
    assert 'http-equiv="refresh"' not in page and "interrupted" in page


def test_show_prints_warnings(evil_run):

    out = run_tuner("show", str(evil_run))
    assert out.returncode == 0 and "warning: " in out.stdout and "evaluations failed" in out.stdout
    js = run_tuner("show", str(evil_run), "--json")
    assert any(w["kind"] == "failed" for w in json.loads(js.stdout)["warnings"])


@pytest.fixture(scope="module")
def sweep_dir(tmp_path_factory, evil_run):

    def build(tmp):
        base = _raw("s")
        doc = {"sweep": {"name": "hostile", "description": EVIL_TEXT, "base": base,
                         "variants": {"pso": {}, "de": {"optimizer.method": "de"}}, "seeds": [1, 2]}}
        (tmp / "sweep.yaml").write_text(yaml.safe_dump(doc))
        out = run_tuner("sweep", tmp / "sweep.yaml", "--dir", tmp / "sw", "-q")  # the objective: this module
        assert out.returncode == 0, out.stderr

    return built_once(tmp_path_factory, "sweep", build) / "sw"


def test_sweep_report_links_html_and_is_inert(sweep_dir):
    page = (sweep_dir / "report.html").read_text()
    _assert_safe(page)
    assert 'href="jobs/pso__seed-1/report.html"' in page and ".md\"" not in page
    assert "## Warnings" in (sweep_dir / "report.md").read_text()
    assert (sweep_dir / "figures" / "best_parameters.png").exists()
    assert "http-equiv=\"refresh\"" not in page


def test_sweep_live_report_reloads_until_every_job_finished(sweep_dir, tmp_path):
    from tuner.sweep import write_sweep_report

    copy = tmp_path / "sw"
    shutil.copytree(sweep_dir, copy)
    meta_p = copy / "jobs" / "de__seed-2" / "meta.json"
    meta = json.loads(meta_p.read_text())
    meta_p.write_text(json.dumps({**meta, "status": "running"}))
    write_sweep_report(copy, live=True)
    page = (copy / "report.html").read_text()
    assert '<meta http-equiv="refresh"' in page and "Live view" in page
    meta_p.write_text(json.dumps(meta))
    write_sweep_report(copy, live=True)
    assert 'http-equiv="refresh"' not in (copy / "report.html").read_text()


# --- a real browser ------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def filter_run(tmp_path_factory, broad_dir):
    """Madgwick on two BROAD trials, scored on a third: the time series with a recording selector."""
    spec = {"dir": str(broad_dir), "stop_s": 60}
    raw = {"name": "madgwick", "seed": 1,
           "objective": {"kind": "filter", "filter": "madgwick", "metric": "broad_mean_rmse",
                         "fixed": {"init": "broad"},
                         "data": {"train": [{"broad": {**spec, "trials": ["01_undisturbed_slow_rotation_A",
                                                                          "07_undisturbed_fast_rotation_B"]}}],
                                  "test": [{"broad": {**spec, "trial": "28_disturbed_stationary_magnet_A"}}]}},
           "parameters": {"beta": {"low": 0.005, "high": 0.5, "scale": "log"}, "zeta": {"low": 0.0, "high": 0.05}},
           "optimizer": {"method": "pso", "population": 6, "generations": 2}, "parallel": {"backend": "serial"}}

    def build(tmp):
        run(config_from_dict(raw, base_dir=tmp), run_dir=tmp / "run", quiet=True)

    return built_once(tmp_path_factory, "filter", build) / "run"


def test_filter_report_shows_the_worst_recording_first(filter_run):
    from tuner.interactive import read_traces

    scores = __import__("pandas").read_csv(filter_run / "scores.csv")
    worst = scores.sort_values("total_rmse_deg", ascending=False)["recording"].tolist()
    traces = read_traces(filter_run)
    assert [it["name"] for it in traces["items"]] == worst  # every recording, worst first
    assert {p["title"] for p in traces["items"][0]["panels"]} >= {"heading error", "inclination error"}
    figure = f"errors_{worst[0].replace('@', '_')}.png"  # a 60 s window's name (trial@0s-60s) as a file name
    assert (filter_run / "figures" / figure).exists()
    md = (filter_run / "report.md").read_text()
    assert f"(figures/{figure})" in md and "summary table" not in md  # the terminal table is not repeated
    assert "| train fitness |" not in md and "| best fitness |" in md  # the best fitness is the train fitness
    assert "| beta | " in md and "rad/s |" in md  # units in the best-parameters table


@pytest.fixture(scope="module")
def dashboard_dir(tmp_path_factory, evil_run, sweep_dir, filter_run):

    def build(tmp):
        root = tmp / "runs"
        root.mkdir()
        shutil.copytree(evil_run, root / "evil")
        shutil.copytree(filter_run, root / "madgwick")
        shutil.copytree(sweep_dir, root / "sweeps" / "hostile")
        out = run_tuner("report", root)
        assert out.returncode == 0 and out.stdout.strip() == str(root / "index.html"), out.stderr

    return built_once(tmp_path_factory, "dashboard", build) / "runs"


def test_dashboard_lists_every_run_and_sweep(dashboard_dir):
    from tuner.dashboard import collect_runs

    rows = {r["id"]: r for r in collect_runs(dashboard_dir)}
    assert set(rows) == {"evil", "madgwick", "sweeps/hostile"} | {f"sweeps/hostile/jobs/{m}__seed-{s}"
                                                                   for m in ("pso", "de") for s in (1, 2)}
    m = rows["madgwick"]
    best = yaml.safe_load((dashboard_dir / "madgwick" / "best.yaml").read_text())
    assert m["target"] == "madgwick" and m["status"] == "finished" and m["best"] == best["fitness"]
    assert m["href"] == "madgwick/report.html" and m["conv"]["y"][-1] == best["fitness"]
    sw = rows["sweeps/hostile"]
    assert sw["kind"] == "sweep" and sw["n_evals"] == sum(rows[k]["n_evals"] for k in rows if "/jobs/" in k)
    page = (dashboard_dir / "index.html").read_text()
    _assert_safe(page)
    assert "http-equiv=\"refresh\"" not in page  # nothing running


def test_dashboard_without_plotly_is_a_static_table(dashboard_dir, tmp_path, monkeypatch):
    from tuner import interactive
    from tuner.dashboard import write_dashboard

    root = tmp_path / "runs"
    shutil.copytree(dashboard_dir, root)
    monkeypatch.setattr(interactive, "available", lambda: False)
    page = write_dashboard(root).read_text()
    _assert_inert(page)
    assert 'href="madgwick/report.html"' in page and 'href="sweeps/hostile/report.html"' in page
    assert page.count("<tr>") == 1 + 7 and "madgwick</td>" in page


def test_dashboard_refreshes_while_a_run_is_going(dashboard_dir, tmp_path):
    from tuner.report import write_live_report

    root = tmp_path / "runs"
    shutil.copytree(dashboard_dir, root)
    d = root / "evil"
    meta = json.loads((d / "meta.json").read_text())
    running = {**meta, "status": "running"}
    (d / "meta.json").write_text(json.dumps(running))
    write_live_report(d, running, min_interval_s=0.0)  # the run's live view rewrites the dashboard above it
    assert 'http-equiv="refresh"' in (root / "index.html").read_text()
    (d / "meta.json").write_text(json.dumps(meta))
    write_live_report(d, {**meta, "status": "interrupted"}, final=True)
    assert 'http-equiv="refresh"' not in (root / "index.html").read_text()


def test_dashboard_of_a_folder_without_runs_is_an_error(tmp_path):

    out = run_tuner("dashboard", tmp_path)
    assert out.returncode == 2 and out.stderr.startswith("error: ") and "no run or sweep" in out.stderr


def _num(x):
    try:
        return float(x.rstrip("%").replace(",", ""))
    except ValueError:
        return None


def _check_sorted(sorts):
    assert sorts, "no sortable table"
    for s in sorts:
        nums = [_num(x) for x in s["after"]]
        first_text = next((i for i, v in enumerate(nums) if v is None), len(nums))
        assert all(v is None for v in nums[first_text:]), s  # numbers first, then text
        assert nums[:first_text] == sorted(nums[:first_text]), s
        assert s["aria"] == "ascending" and sorted(s["after"]) == sorted(s["before"]), s
    assert any(s["before"] != s["after"] for s in sorts), "no click reordered a table"


@needs_chromium
@pytest.mark.parametrize("width", [1200, 390])
@pytest.mark.parametrize("which", ["run", "filter_run", "sweep", "dashboard"])
def test_pages_in_a_browser(which, width, request, browser):
    import numpy as np
    from PIL import Image

    from tuner import interactive

    folder = request.getfixturevalue({"run": "evil_run", "filter_run": "filter_run", "sweep": "sweep_dir",
                                      "dashboard": "dashboard_dir"}[which])
    page = folder / ("index.html" if which == "dashboard" else "report.html")
    res = measure(page, browser, width)
    assert res["innerWidth"] == width
    assert res["scrollWidth"] <= res["innerWidth"], res  # no horizontal overflow of the page
    assert res["wide"] == [], res  # nothing sticks out except inside scroll containers
    assert res["broken"] == [], res  # every figure decodes
    assert res["errors"] == [], res  # no console error, no CSP violation
    if interactive.available():
        _check_sorted(res["sorts"])
        want = {"run": 5, "filter_run": 6, "sweep": 1, "dashboard": 2}[which]
        assert len(res["plots"]) == want, res["plots"]
        for p in res["plots"]:  # every plot drawn, with data, within the page
            assert p["rendered"] and p["drawn"] > 0 and 0 < p["width"] <= width and p["height"] > 100, p
        if which == "filter_run":  # the recording selector redraws the time series
            assert res["selector"]["options"] == 3 and res["selector"]["changed"] is True, res["selector"]
        if which == "dashboard":
            d = res["dashboard"]
            assert d["rows"] == 7 and 1 <= d["shown"] < d["rows"], d  # the filter hides rows
            assert res["plots"][1]["name"] == "compare-convergence" and res["plots"][1]["traces"] == 2
    else:
        assert res["images"] >= 3
    shot = screenshot(page, output_dir() / f"{which}_{width}.png", browser, width, 7000 if width < 500 else 5000,
                      "#compare=evil,madgwick" if which == "dashboard" else "")
    arr = np.asarray(Image.open(shot).convert("L"), dtype=float)
    assert arr.std() > 5 and (arr < 128).mean() > 0.005, "blank screenshot"


@needs_chromium
def test_browser_measurement_catches_overflow_broken_images_and_broken_plots(evil_run, browser, tmp_path):
    """Negative control: the same measurement on pages that overflow, hold a broken image, a plot whose data
    is damaged and a plot whose script did not load."""
    from tuner import interactive

    bad = tmp_path / "bad"
    shutil.copytree(evil_run, bad)
    page = (evil_run / "report.html").read_text()
    page = page.replace("<main>", '<main><div style="width:2500px">wide</div>'
                                  '<img src="data:image/png;base64,AAAA" alt="broken">', 1)
    (bad / "report.html").write_text(page)
    res = measure(bad / "report.html", browser)
    assert res["scrollWidth"] > 2000 and res["wide"] and res["broken"] == ["broken"] and res["errors"]
    if not interactive.available():
        return
    good = (evil_run / "report.html").read_text()
    (bad / "report.html").write_text(good.replace('"best":[', '"best":[],"best_damaged":[', 1)
                                     .replace('"gen_median":[', '"gen_median":[],"gen_median_damaged":[', 1))
    conv = next(p for p in measure(bad / "report.html", browser)["plots"] if p["name"] == "convergence")
    assert conv["rendered"] and conv["drawn"] == 0, conv  # the axes are there, the data is not: caught
    (bad / "report.html").write_text(good.replace('"convergence":{', '"convergence_damaged":{', 1))
    res = measure(bad / "report.html", browser)
    conv = next(p for p in res["plots"] if p["name"] == "convergence")
    assert not conv["rendered"] and conv["drawn"] == 0 and any("convergence" in e for e in res["errors"]), res
    (bad / "report.html").write_text((evil_run / "report.html").read_text())
    (bad / "plotly.min.js").unlink()
    res = measure(bad / "report.html", browser)
    assert res["errors"] and not any(p["rendered"] for p in res["plots"]), res


@needs_chromium
def test_report_with_cross_validation_in_a_browser(browser, tmp_path):
    # the Generalisation section (validation: cv) adds a table and a warning: it must fit the page too
    from tests.tuner.test_validation import _raw as _val_raw

    cfg = config_from_dict(_val_raw(tmp_path, {"cv": "kfold", "folds": 2, "budget_fraction": 0.5, "gap_warn_rel": 0.0}))
    page = run(cfg, quiet=True).run_dir / "report.html"
    assert "Generalisation" in page.read_text()
    res = measure(page, browser, 390)
    assert res["scrollWidth"] <= res["innerWidth"] and res["wide"] == [], res
    assert res["broken"] == [] and res["errors"] == [], res


LONG = "a_variant_whose_name_says_everything_about_it"  # job ids of 90+ characters with the grid


@pytest.fixture(scope="module")
def long_names_dir(tmp_path_factory):
    """A folder of runs holding a sweep whose job names are long (variant and three grid values)."""
    def build(tmp):
        base = {"name": "l", "seed": 1, "objective": {"kind": "function", "function": "sphere", "dim": 2},
                "optimizer": {"method": "pso", "population": 4, "generations": 2}, "parallel": {"backend": "serial"}}
        doc = {"sweep": {"name": "long_names_of_jobs", "base": base, "variants": {LONG: {}, "pso": {}},
                         "grid": {"optimizer.population": [4], "optimizer.generations": [2], "objective.dim": [2]},
                         "seeds": [1, 2]}}
        (tmp / "sweep.yaml").write_text(yaml.safe_dump(doc))
        out = run_tuner("sweep", tmp / "sweep.yaml", "--dir", tmp / "runs" / "sweeps" / "long", "-q")
        assert out.returncode == 0, out.stderr
        assert run_tuner("dashboard", tmp / "runs").returncode == 0

    return built_once(tmp_path_factory, "long-names", build) / "runs"


#: the right edge (px) of every cell under a header named in HEADS, and the viewport width
_EDGES = """(function () {
  var HEADS = %s, out = {width: window.innerWidth, cells: []};
  [].forEach.call(document.querySelectorAll('table'), function (t) {
    var heads = [].map.call(t.querySelectorAll('thead th'), function (h) { return h.textContent.trim(); });
    heads.forEach(function (h, i) {
      if (HEADS.indexOf(h) < 0) { return; }
      [].forEach.call(t.querySelectorAll('tbody tr'), function (r) {
        var c = r.cells[i];
        if (c) { out.cells.push({head: h, text: c.textContent, right: Math.round(c.getBoundingClientRect().right)}); }
      });
    });
  });
  return out;
})()"""


@needs_chromium
@pytest.mark.parametrize("page, heads", [("index.html", ["status", "best"]),
                                         ("sweeps/long/report.html", ["status", "best_fitness"])])
def test_long_job_names_keep_status_and_best_on_screen_at_1200_px(long_names_dir, browser, page, heads):
    """Long sweep job names pushed the status and best columns off-screen (into the table's horizontal
    scroll) at 1200 px: the name cells wrap instead."""
    path = long_names_dir / page
    assert LONG[:40] in path.read_text()  # (a job id keeps 40 characters of each part)
    with browser.open(path.resolve().as_uri(), 1200, 900, 4000) as p:
        res = p.evaluate(_EDGES % json.dumps(heads))
    cells = [c for c in res["cells"] if c["head"] in heads]
    assert len(cells) >= 8, res
    off = [c for c in cells if c["right"] > res["width"]]
    assert not off, off
