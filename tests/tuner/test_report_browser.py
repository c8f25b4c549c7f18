"""Run and sweep reports: content, hostile names neutralised, the live view, and a real headless browser
at 1200 px (no horizontal overflow, every image decodes, no console or CSP error)."""

import json
import math
import re
import shutil
import subprocess

import pytest
import yaml

from tests.tuner.test_render import _assert_inert
from tuner.config import config_from_dict
from tuner.run import run

pytestmark = pytest.mark.slow  # every test here tunes, sweeps or drives a browser

EVIL_METRIC = "<script>alert('m')</script>"
EVIL_REC = "[x](javascript:alert('r'))"
EVIL_TEXT = "<img src=x onerror=alert('d')> [y](javascript:alert('d')) <script>alert('d')</script>"


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
    tmp = tmp_path_factory.mktemp("evil")
    return run(config_from_dict(_raw("evil"), base_dir=tmp), run_dir=tmp / "run", quiet=True).run_dir


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


def test_hostile_names_are_neutralised(evil_run):
    page = (evil_run / "report.html").read_text()
    _assert_inert(page)
    assert "&lt;img src=x onerror=alert('d')&gt;" in page  # description and string parameter shown as text
    assert "[x](javascript:alert('r'))" in page  # recording name shown literally, not as a link


def test_multiline_values_stay_out_of_tables(tmp_path):
    from tuner.report import write_run_report

    src = tmp_path / "r"
    raw = {"name": "m", "seed": 1, "objective": {"kind": "function", "function": "sphere", "dim": 2},
           "optimizer": {"method": "random", "population": 4, "generations": 1}, "parallel": {"backend": "serial"}}
    d = run(config_from_dict(raw, base_dir=tmp_path), run_dir=src, quiet=True).run_dir
    best = yaml.safe_load((d / "best.yaml").read_text())
    best["evaluation"] = {"summary_table": "a | b\n--- | ---\n1 | 2", "test_fitness": 4.5e-9,
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
    import sys

    from tuner.report import write_live_report

    d = tmp_path / "copy"
    shutil.copytree(evil_run, d)
    meta = json.loads((d / "meta.json").read_text())
    running = {**meta, "status": "running"}
    (d / "meta.json").write_text(json.dumps(running))
    assert write_live_report(d, running, final=True) is None  # no live report yet: nothing to replace
    assert write_live_report(d, running, min_interval_s=0.0) == d / "report.md"
    assert 'http-equiv="refresh"' in (d / "report.html").read_text()
    show = subprocess.run([sys.executable, "-m", "tuner", "show", str(d)], capture_output=True, text=True, timeout=120)
    assert show.returncode == 0 and "running" in show.stdout  # tuner show works on a running run
    stopped = {**meta, "status": "interrupted"}
    assert write_live_report(d, stopped, final=True) == d / "report.md"
    page = (d / "report.html").read_text()
    assert 'http-equiv="refresh"' not in page and "interrupted" in page


def test_show_prints_warnings(evil_run):
    import sys

    out = subprocess.run([sys.executable, "-m", "tuner", "show", str(evil_run)], capture_output=True, text=True,
                         timeout=120)
    assert out.returncode == 0 and "warning: " in out.stdout and "evaluations failed" in out.stdout
    js = subprocess.run([sys.executable, "-m", "tuner", "show", str(evil_run), "--json"], capture_output=True,
                        text=True, timeout=120)
    assert any(w["kind"] == "failed" for w in json.loads(js.stdout)["warnings"])


@pytest.fixture(scope="module")
def sweep_dir(tmp_path_factory, evil_run):
    import sys

    tmp = tmp_path_factory.mktemp("sweep")
    base = _raw("s")
    doc = {"sweep": {"name": "hostile", "description": EVIL_TEXT, "base": base,
                     "variants": {"pso": {}, "de": {"optimizer.method": "de"}}, "seeds": [1, 2]}}
    (tmp / "sweep.yaml").write_text(yaml.safe_dump(doc))
    out = subprocess.run([sys.executable, "-m", "tuner", "sweep", str(tmp / "sweep.yaml"), "--dir", str(tmp / "sw"),
                          "-q"], capture_output=True, text=True, timeout=600)
    assert out.returncode == 0, out.stderr
    return tmp / "sw"


def test_sweep_report_links_html_and_is_inert(sweep_dir):
    page = (sweep_dir / "report.html").read_text()
    _assert_inert(page)
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
def _chromium():
    for name in ("chromium", "chromium-browser", "google-chrome", "google-chrome-stable"):
        if shutil.which(name):
            return shutil.which(name)
    return None


MEASURE = """<script nonce="measure">
window.__errors = [];
window.addEventListener('error', function (e) {
  var t = e.target && e.target !== window ? ' ' + e.target.tagName : '';
  window.__errors.push('error' + t + ': ' + (e.message || ''));
}, true);
document.addEventListener('securitypolicyviolation', function (e) {
  window.__errors.push('csp: ' + e.violatedDirective + ' ' + e.blockedURI);
});
['error', 'warn'].forEach(function (k) {
  var orig = console[k];
  console[k] = function () {
    window.__errors.push('console.' + k + ': ' + [].join.call(arguments, ' '));
    orig.apply(console, arguments);
  };
});
window.addEventListener('load', function () {
  var imgs = [].slice.call(document.images);
  var wide = [].slice.call(document.querySelectorAll('body *')).filter(function (el) {
    return el.getBoundingClientRect().right > window.innerWidth + 0.5 && !el.closest('.table-scroll, pre');
  }).map(function (el) { return el.tagName + '.' + el.className; });
  var res = {scrollWidth: document.documentElement.scrollWidth, innerWidth: window.innerWidth,
             images: imgs.length, broken: imgs.filter(function (i) { return !(i.complete && i.naturalWidth > 0); })
             .map(function (i) { return i.alt; }), errors: window.__errors, wide: wide.slice(0, 10)};
  var pre = document.createElement('pre');
  pre.id = 'measure';
  pre.textContent = JSON.stringify(res);
  document.body.appendChild(pre);
});
</script>
"""


def _measure(page_path, tmp_path, width=1200):
    """Open a copy of the page with a measuring script (allowed by nonce) in headless Chromium."""
    html = page_path.read_text()
    assert "default-src 'none';" in html
    html = html.replace("default-src 'none';", "default-src 'none'; script-src 'nonce-measure';", 1)
    html = html.replace("<head>\n", "<head>\n" + MEASURE, 1)
    probe = page_path.parent / "_measure.html"  # beside the report: same relative paths
    probe.write_text(html)
    try:
        out = subprocess.run([_chromium(), "--headless", "--no-sandbox", "--disable-gpu", "--no-first-run",
                              "--disable-background-networking", "--disable-component-update", "--disable-sync",
                              "--hide-scrollbars", f"--user-data-dir={tmp_path / 'profile'}",
                              f"--window-size={width},900", "--virtual-time-budget=10000", "--dump-dom",
                              f"file://{probe}"], capture_output=True, text=True, timeout=180)
    finally:
        probe.unlink()
    m = re.search(r'<pre id="measure">(.*?)</pre>', out.stdout, re.S)
    assert m, f"no measurement in the DOM; stderr: {out.stderr[-2000:]}"
    import html as _h

    return json.loads(_h.unescape(m.group(1)))


def _screenshot(page_path, tmp_path, width=1200):
    shot = tmp_path / f"{page_path.parent.name}.png"
    subprocess.run([_chromium(), "--headless", "--no-sandbox", "--disable-gpu", "--no-first-run", "--hide-scrollbars",
                    f"--user-data-dir={tmp_path / 'profile2'}", f"--screenshot={shot}", f"--window-size={width},3000",
                    f"file://{page_path}"], capture_output=True, timeout=180)
    return shot


@pytest.mark.skipif(_chromium() is None, reason="Chromium not installed (.ci/run installs it)")
@pytest.mark.parametrize("which", ["run", "sweep"])
def test_report_in_a_browser_at_1200px(which, evil_run, sweep_dir, tmp_path):
    import numpy as np
    from PIL import Image

    page = (evil_run if which == "run" else sweep_dir) / "report.html"
    res = _measure(page, tmp_path)
    assert res["innerWidth"] == 1200
    assert res["scrollWidth"] <= res["innerWidth"], res  # no horizontal overflow of the page
    assert res["wide"] == [], res  # nothing sticks out except inside scroll containers
    assert res["images"] >= 3 and res["broken"] == [], res  # every figure decodes
    assert res["errors"] == [], res  # no console error, no CSP violation
    shot = _screenshot(page, tmp_path)
    arr = np.asarray(Image.open(shot).convert("L"), dtype=float)
    assert arr.std() > 5 and (arr < 128).mean() > 0.005, "blank screenshot"


@pytest.mark.skipif(_chromium() is None, reason="Chromium not installed (.ci/run installs it)")
def test_browser_measurement_catches_overflow_and_broken_images(evil_run, tmp_path):
    """Negative control: the same measurement on a page that does overflow and has a broken image."""
    bad = tmp_path / "bad"
    bad.mkdir()
    page = (evil_run / "report.html").read_text()
    page = page.replace("<main>", '<main><div style="width:2500px">wide</div>'
                                  '<img src="data:image/png;base64,AAAA" alt="broken">', 1)
    (bad / "report.html").write_text(page)
    res = _measure(bad / "report.html", tmp_path)
    assert res["scrollWidth"] > 2000 and res["wide"] and res["broken"] == ["broken"] and res["errors"]


@pytest.mark.skipif(_chromium() is None, reason="Chromium not installed (.ci/run installs it)")
def test_report_with_cross_validation_in_a_browser(tmp_path):
    # the Generalisation section (validation: cv) adds a table and a warning: it must fit the page too
    from tests.tuner.test_validation import _raw as _val_raw

    cfg = config_from_dict(_val_raw(tmp_path, {"cv": "kfold", "folds": 2, "budget_fraction": 0.5, "gap_warn_rel": 0.0}))
    page = run(cfg, quiet=True).run_dir / "report.html"
    assert "Generalisation" in page.read_text()
    res = _measure(page, tmp_path)
    assert res["scrollWidth"] <= res["innerWidth"] and res["wide"] == [], res
    assert res["broken"] == [] and res["errors"] == [], res
