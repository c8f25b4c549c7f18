"""The closed loop's report: it leads with the tuned gains and the requirements in words, and its first screen in
headless Chromium (1200 px and 390 px) shows the gains and the first requirement's verdict without overflow
(screenshots in ``$TUNER_TEST_OUTPUT/browser/``)."""

import json
from pathlib import Path

import pytest
import yaml

from tests.conftest import built_once
from tests.tuner.browser import measure, needs_chromium, output_dir, screenshot
from tuner.config import config_from_dict
from tuner.run import run

pytestmark = pytest.mark.slow  # a tuning and a browser


@pytest.fixture(scope="module")
def loop_run(tmp_path_factory):
    """The saturation trap (configs/examples/dc_motor_saturation.yaml) at a short budget: a closed loop whose
    report leads with the gains and the requirements table."""
    raw = yaml.safe_load((Path(__file__).resolve().parents[2] / "configs" / "examples" /
                          "dc_motor_saturation.yaml").read_text())
    raw["optimizer"] = {"method": "pso", "population": 10, "generations": 6}

    def build(tmp):
        run(config_from_dict(raw, base_dir=tmp), run_dir=tmp / "run", quiet=True)

    return built_once(tmp_path_factory, "loop", build) / "run"


def test_loop_report_leads_with_gains_and_requirements_in_words(loop_run):
    md = (loop_run / "report.md").read_text()
    lead = md.index("## Tuned controller")
    assert lead < md.index("## Requirements") < md.index("## Summary")
    assert "| K | " in md[lead:md.index("## Requirements")] and "u/y |" in md
    assert "[requirements.md](requirements.md)" in md and "- [requirements.md](requirements.md)" in md
    assert "| maximum sensitivity Ms | ms |" in md and "| phase margin (deg) | pm_deg |" in md  # words, then key
    assert "1e+12" not in md and "initial fitness | failed: requirement violated" in md  # the defaults fail
    assert md.count("```") == 0  # no code block repeats the lead or the terminal table


@needs_chromium
@pytest.mark.parametrize("width", [1200, 390])
def test_loop_report_first_view_in_a_browser(loop_run, browser, width):
    """At 390 px the first screen (900 px high) shows the gains' table and the requirements table's first row
    with its verdict in view; nothing overflows the page."""
    page = loop_run / "report.html"
    res = measure(page, browser, width)
    assert res["scrollWidth"] <= res["innerWidth"] and res["wide"] == [], res
    assert res["broken"] == [] and res["errors"] == [], res
    js = """(function () {
      var hs = Array.from(document.querySelectorAll('h2'));
      function top(text) { var h = hs.find(function (x) { return x.textContent.trim() === text; });
                           return h ? h.getBoundingClientRect().top : -1; }
      var tables = Array.from(document.querySelectorAll('table'));
      var req = tables[1] ? tables[1].querySelector('tbody tr') : null;
      var met = req ? req.cells[1].getBoundingClientRect() : null;
      return JSON.stringify({gains: top('Tuned controller'), reqs: top('Requirements'), summary: top('Summary'),
                             firstRow: req ? req.getBoundingClientRect().bottom : -1,
                             firstCell: req ? req.cells[0].textContent : '', met: req ? req.cells[1].textContent : '',
                             metRight: met ? met.right : 1e9, small: req ? req.cells[4].textContent : ''});
    })()"""
    with browser.open(page.resolve().as_uri(), width, 900, 8000) as p:
        pos = json.loads(p.evaluate(js))
    assert 0 <= pos["gains"] < pos["reqs"] < pos["summary"], pos
    assert 0 < pos["firstRow"] <= 900 and pos["firstCell"] == "overshoot (%)", pos
    assert pos["met"] == "yes" and pos["metRight"] <= width, pos  # the verdict is on screen, not scrolled off
    assert "NO: met only through saturation" in pos["small"], pos
    screenshot(page, output_dir() / f"loop_{width}.png", browser, width, 1800)
