"""Headless Chromium checks of report pages: errors, overflow, images, plots, sortable tables, screenshots.

``measure(page)`` opens a copy of ``page`` (beside it, so relative paths hold) with a measuring script
admitted by a nonce, lets the page's own scripts run (virtual time), clicks the header of a table to sort
it, and returns what it found as a dict:

- ``errors``: console errors and warnings, uncaught exceptions, failed loads, CSP violations;
- ``scrollWidth``/``innerWidth`` and ``wide``: elements sticking out of the page outside a scroll container;
- ``images``/``broken``: ``<img>`` that did not decode;
- ``plots``: per ``div.tuner-plot``: its name, whether the script marked it drawn, its size and the number
  of drawn traces (plotly ``g.trace`` groups) -- an empty or failed plot has 0;
- ``sorts``: per sortable table, a column's cells before and after a click on its header;
- ``dashboard``: rows shown after typing into the filter, and plots after ticking the last two rows;
- ``selector``: a time-series selector switched to its last entry, and whether the plot changed.
"""

from __future__ import annotations

import html as _h
import json
import re
import shutil
import subprocess
from pathlib import Path

__all__ = ["chromium", "measure", "screenshot"]


def chromium() -> str | None:
    for name in ("chromium", "chromium-browser", "google-chrome", "google-chrome-stable"):
        if shutil.which(name):
            return shutil.which(name)
    return None


MEASURE = r"""<script nonce="measure">
window.__errors = [];
window.addEventListener('error', function (e) {
  var t = e.target && e.target !== window ? ' ' + e.target.tagName + ' ' + (e.target.src || '') : '';
  window.__errors.push('error' + t + ': ' + (e.message || ''));
}, true);
window.addEventListener('unhandledrejection', function (e) { window.__errors.push('rejection: ' + e.reason); });
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
function __plots() {
  return [].slice.call(document.querySelectorAll('div.tuner-plot')).map(function (d) {
    var r = d.getBoundingClientRect();
    return {name: d.getAttribute('data-plot'), rendered: d.getAttribute('data-rendered') === '1',
            width: Math.round(r.width), height: Math.round(r.height), traces: d.querySelectorAll('g.trace').length,
            drawn: [].filter.call(d.querySelectorAll('g.trace path, g.trace image'),
              function (p) { return p.tagName.toLowerCase() === 'image' || (p.getAttribute('d') || '').length > 10; }
            ).length};
  });
}
function __wide() {
  return [].slice.call(document.querySelectorAll('body *')).filter(function (el) {
    return el.getBoundingClientRect().right > window.innerWidth + 0.5 && !el.closest('.table-scroll, pre');
  }).map(function (el) { return el.tagName + '.' + el.className; }).slice(0, 10);
}
function __sorts() {
  var out = [];
  [].forEach.call(document.querySelectorAll('table[data-sortable="1"]'), function (t) {
    if (!t.tBodies[0] || t.tBodies[0].rows.length < 2 || t.closest('#compare')) { return; }
    var ths = t.tHead.rows[0].cells, col = ths.length - 1;
    var nums = function (c) { return [].map.call(t.tBodies[0].rows, function (r) {
      return r.style.display === 'none' ? null : (r.cells[c] ? r.cells[c].textContent.trim() : ''); }).filter(
      function (x) { return x !== null; }); };
    for (var c = ths.length - 1; c >= 0; c--) {  /* the last column with two different values */
      var v = nums(c);
      if (v.some(function (x) { return x !== v[0]; })) { col = c; break; }
    }
    var before = nums(col);
    ths[col].click();
    out.push({head: ths[col].textContent, before: before, after: nums(col), aria: ths[col].getAttribute('aria-sort')});
  });
  return out;
}
function __lines(div) {
  return [].map.call(div.querySelectorAll('g.trace path'), function (p) {
    return p.getAttribute('d') || ''; }).join('|');
}
window.addEventListener('load', function () {
  setTimeout(function () {
    var res = {plots_before: __plots()};
    var sel = document.querySelector('div.tuner-plot select');
    if (sel) {  /* pick the last recording: the time series must be redrawn */
      var box = sel.closest('div.tuner-plot'), before = __lines(box);
      sel.value = String(sel.options.length - 1);
      sel.dispatchEvent(new Event('change'));
      res.selector = {options: sel.options.length, before: before.length, changed: null};
      setTimeout(function () { res.selector.changed = __lines(box) !== before; }, 500);
    }
    var input = document.querySelector('input[type=search]');
    if (input) {
      var rows = document.querySelectorAll('#runs-table tbody tr');
      var first = rows.length ? rows[rows.length - 1].cells[4].textContent : '';
      input.value = first;
      input.dispatchEvent(new Event('input'));
      res.dashboard = {rows: rows.length, filter: first, shown: [].filter.call(rows, function (r) {
        return r.style.display !== 'none'; }).length};
      input.value = '';
      input.dispatchEvent(new Event('input'));
      [].slice.call(document.querySelectorAll('#runs-table tbody input[type=checkbox]'), -2).forEach(
        function (cb) { if (!cb.checked) { cb.click(); } });
    }
    setTimeout(function () {
      var imgs = [].slice.call(document.images);
      res.scrollWidth = document.documentElement.scrollWidth;
      res.innerWidth = window.innerWidth;
      res.images = imgs.length;
      res.broken = imgs.filter(function (i) { return !(i.complete && i.naturalWidth > 0); })
        .map(function (i) { return i.alt; });
      res.plots = __plots();
      res.wide = __wide();
      res.sorts = __sorts();
      res.errors = window.__errors;
      var pre = document.createElement('pre');
      pre.id = 'measure';
      pre.textContent = JSON.stringify(res);
      document.body.appendChild(pre);
    }, 1500);
  }, 2500);
});
</script>
"""

_FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--no-first-run", "--disable-background-networking",
          "--disable-component-update", "--disable-sync", "--hide-scrollbars", "--force-device-scale-factor=1",
          "--allow-file-access-from-files"]  # the 390 px frame reads its page's measurement


def measure(page_path: Path, tmp_path: Path, width: int = 1200) -> dict:
    """Open a copy of ``page_path`` with the measuring script in headless Chromium (module docstring)."""
    page_path = Path(page_path)
    text = page_path.read_text()
    if "script-src 'self';" in text:
        text = text.replace("script-src 'self';", "script-src 'self' 'nonce-measure';", 1)
    else:
        assert "default-src 'none';" in text
        text = text.replace("default-src 'none';", "default-src 'none'; script-src 'nonce-measure';", 1)
    text = text.replace("<head>\n", "<head>\n" + MEASURE, 1)
    probe = page_path.parent / "_measure.html"  # beside the page: same relative paths
    probe.write_text(text)
    frame = _frame(probe, width, 900, copy_result=True)
    try:
        out = subprocess.run([chromium(), *_FLAGS, f"--user-data-dir={tmp_path / 'profile'}",
                              f"--window-size={max(width, 600)},900", "--virtual-time-budget=20000", "--dump-dom",
                              f"file://{frame or probe}"], capture_output=True, text=True, timeout=240)
    finally:
        probe.unlink()
        if frame:
            frame.unlink()
    m = re.search(r'<pre id="measure">(.*?)</pre>', out.stdout, re.S)
    assert m, f"no measurement in the DOM; stderr: {out.stderr[-2000:]}"
    return json.loads(_h.unescape(m.group(1)))


#: headless Chromium does not make a window narrower than this; a narrower page is shown in an iframe
MIN_WINDOW = 500


def _frame(page: Path, width: int, height: int, copy_result: bool = False, fragment: str = "") -> Path | None:
    """For ``width`` < :data:`MIN_WINDOW`: a page beside ``page`` showing it in a ``width`` px iframe."""
    if width >= MIN_WINDOW:
        return None
    copy = """<script>
setInterval(function () {
  var d = document.querySelector('iframe').contentDocument, m = d && d.getElementById('measure');
  if (m && !document.getElementById('measure')) {
    var pre = document.createElement('pre'); pre.id = 'measure'; pre.textContent = m.textContent;
    document.body.appendChild(pre);
  }
}, 200);
</script>""" if copy_result else ""
    frame = page.parent / f"_frame_{page.stem}.html"
    frame.write_text(f'<!DOCTYPE html><html><head><meta charset="utf-8"></head><body style="margin:0">'
                     f'<iframe src="{page.name}{fragment}" '
                     f'style="width:{width}px;height:{height}px;border:0;display:block">'
                     f"</iframe>{copy}</body></html>")
    return frame


def screenshot(page_path: Path, out: Path, tmp_path: Path, width: int = 1200, height: int = 3000,
               fragment: str = "") -> Path:
    """A PNG of the top ``height`` px of the page (URL + ``fragment``) at ``width`` px, after its scripts ran.

    Below :data:`MIN_WINDOW` px the window is 500 px wide and the page fills the left ``width`` px.
    """
    out.parent.mkdir(parents=True, exist_ok=True)
    frame = _frame(Path(page_path), width, height, fragment=fragment)
    try:
        subprocess.run([chromium(), *_FLAGS, f"--user-data-dir={tmp_path / 'profile2'}", f"--screenshot={out}",
                        f"--window-size={max(width, MIN_WINDOW)},{height}", "--virtual-time-budget=8000",
                        f"file://{frame}" if frame else f"file://{Path(page_path)}{fragment}"],
                       capture_output=True, timeout=240)
    finally:
        if frame:
            frame.unlink()
    return out
