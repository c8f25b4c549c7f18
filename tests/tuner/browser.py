"""Headless Chromium checks of report pages: errors, overflow, images, plots, sortable tables, screenshots.

One :class:`Browser` (a Chromium driven over the DevTools protocol on a pipe) serves every page of a test
module: each page opens in a browser context of its own (no cache, storage or renderer process shared
with the pages before it) at a viewport of the asked size, and its timers run on virtual time, as with
Chromium's ``--virtual-time-budget``: the page's scripts run to the end of the budget without waiting in
real time.

``measure(page, browser, width)`` opens ``page`` with a measuring script that runs before the page's own
(so the page's Content-Security-Policy is left as it is), lets the page's scripts run, clicks the header
of a table to sort it, and returns what it found as a dict:

- ``errors``: console errors and warnings, uncaught exceptions, failed loads, CSP violations;
- ``scrollWidth``/``innerWidth`` and ``wide``: elements sticking out of the page outside a scroll container;
- ``images``/``broken``: ``<img>`` that did not decode;
- ``plots``: per ``div.tuner-plot``: its name, whether the script marked it drawn, its size and the number
  of drawn traces (plotly ``g.trace`` groups) -- an empty or failed plot has 0;
- ``sorts``: per sortable table, a column's cells before and after a click on its header;
- ``dashboard``: rows shown after typing into the filter, and plots after ticking the last two rows;
- ``selector``: a time-series selector switched to its last entry, and whether the plot changed.

``screenshot(page, out, browser, width, height)`` writes a PNG of the top of the page.
"""

from __future__ import annotations

import base64
import json
import os
import select
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

__all__ = ["Browser", "chromium", "measure", "screenshot", "needs_chromium", "output_dir"]


def chromium() -> str | None:
    for name in ("chromium", "chromium-browser", "google-chrome", "google-chrome-stable"):
        if shutil.which(name):
            return shutil.which(name)
    return None


MEASURE = r"""
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
"""

_FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--no-first-run", "--disable-background-networking",
          "--disable-component-update", "--disable-sync", "--hide-scrollbars", "--force-device-scale-factor=1"]


#: run argv[3:] with the descriptors argv[1] and argv[2] as its 3 and 4 (a shell's ``3<&N`` takes one digit)
_AS_FD_3_AND_4 = """
import fcntl, os, sys
r, w = (fcntl.fcntl(int(fd), fcntl.F_DUPFD, 10) for fd in sys.argv[1:3])
os.dup2(r, 3)
os.dup2(w, 4)
os.close(r)
os.close(w)
os.execv(sys.argv[3], sys.argv[3:])
"""


class Browser:
    """A headless Chromium for many pages, driven over the DevTools protocol (``--remote-debugging-pipe``:
    commands on its descriptor 3, answers and events on 4, each message JSON ending in a NUL byte).

    ``profile`` is the user-data directory; the browser's own log goes to ``profile/chromium.log``.
    ``timeout_s`` bounds the wait for any one answer or event. Use as a context manager or call
    :meth:`close`.
    """

    def __init__(self, profile: Path, timeout_s: float = 240.0):
        profile = Path(profile)
        profile.mkdir(parents=True, exist_ok=True)
        self.log = profile / "chromium.log"
        self.timeout_s = timeout_s
        cmd_r, self._cmd = os.pipe()  # we write, Chromium reads (its descriptor 3)
        self._ans, ans_w = os.pipe()  # Chromium writes (its descriptor 4), we read
        with open(self.log, "wb") as log:
            self._proc = subprocess.Popen(
                [sys.executable, "-c", _AS_FD_3_AND_4, str(cmd_r), str(ans_w), chromium(), *_FLAGS,
                 f"--user-data-dir={profile}", "--remote-debugging-pipe", "about:blank"],
                pass_fds=(cmd_r, ans_w), stdin=subprocess.DEVNULL, stdout=log, stderr=log)
        os.close(cmd_r)
        os.close(ans_w)
        self._buf, self._id, self._events = b"", 0, []
        self.send("Browser.getVersion")  # up and answering

    def __enter__(self) -> Browser:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def close(self) -> None:
        if self._proc.poll() is None:
            try:
                self.send("Browser.close")
                self._proc.wait(timeout=30)
            except (OSError, RuntimeError, TimeoutError, subprocess.TimeoutExpired):
                self._proc.kill()
                self._proc.wait()
        for fd in (self._cmd, self._ans):
            try:
                os.close(fd)
            except OSError:
                pass

    def _fail(self, what: str) -> str:
        return f"Chromium: {what}; its log ends: {self.log.read_text(errors='replace')[-2000:]}"

    def _receive(self) -> dict:
        while b"\0" not in self._buf:
            ready, _, _ = select.select([self._ans], [], [], self.timeout_s)
            if not ready:
                raise TimeoutError(self._fail(f"no message in {self.timeout_s} s"))
            chunk = os.read(self._ans, 1 << 20)
            if not chunk:
                raise RuntimeError(self._fail("the browser closed its pipe"))
            self._buf += chunk
        msg, self._buf = self._buf.split(b"\0", 1)
        return json.loads(msg)

    def send(self, method: str, params: dict | None = None, session: str | None = None) -> dict:
        """Send one command (to a page when ``session`` is given) and return its result; events that
        arrive meanwhile are kept for :meth:`wait_for`."""
        self._id += 1
        msg = {"id": self._id, "method": method, "params": params or {}}
        if session:
            msg["sessionId"] = session
        os.write(self._cmd, json.dumps(msg).encode() + b"\0")
        while True:
            msg = self._receive()
            if msg.get("id") == self._id:
                if "error" in msg:
                    raise RuntimeError(self._fail(f"{method}: {msg['error']}"))
                return msg["result"]
            self._events.append(msg)

    def wait_for(self, method: str, session: str) -> dict:
        """The next event ``method`` of page ``session``."""
        while True:
            for i, e in enumerate(self._events):
                if e.get("method") == method and e.get("sessionId") == session:
                    return self._events.pop(i)
            self._events.append(self._receive())

    def open(self, url: str, width: int, height: int, budget_ms: int, script: str = "") -> _Page:
        """Load ``url`` in a new browser context at a ``width`` x ``height`` px viewport, ``script`` run in
        the page before its own scripts, and return once ``budget_ms`` of virtual time have passed (timers
        fire without waiting; virtual time stands still while a file or request is loading)."""
        context = self.send("Target.createBrowserContext")["browserContextId"]
        page = _Page(self, context)
        try:
            target = self.send("Target.createTarget", {"url": "about:blank", "browserContextId": context})
            page.session = self.send("Target.attachToTarget", {"targetId": target["targetId"],
                                                               "flatten": True})["sessionId"]
            page.send("Page.enable")
            page.send("Emulation.setDeviceMetricsOverride", {"width": width, "height": height,
                                                             "deviceScaleFactor": 1, "mobile": False})
            if script:
                page.send("Page.addScriptToEvaluateOnNewDocument", {"source": script})
            page.send("Emulation.setVirtualTimePolicy", {"policy": "pause"})  # no timer before the budget
            nav = page.send("Page.navigate", {"url": url})
            assert "errorText" not in nav, (url, nav)
            page.send("Emulation.setVirtualTimePolicy", {"policy": "pauseIfNetworkFetchesPending",
                                                         "budget": budget_ms})
            self.wait_for("Emulation.virtualTimeBudgetExpired", page.session)
        except BaseException:
            page.close()
            raise
        return page


class _Page:
    """A page open in its own browser context (:meth:`Browser.open`); closing it drops the context."""

    def __init__(self, browser: Browser, context: str):
        self.browser, self.context, self.session = browser, context, None

    def __enter__(self) -> _Page:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def send(self, method: str, params: dict | None = None) -> dict:
        return self.browser.send(method, params, self.session)

    def evaluate(self, expression: str):
        out = self.send("Runtime.evaluate", {"expression": expression, "returnByValue": True})
        assert "exceptionDetails" not in out, out
        return out["result"].get("value")

    def close(self) -> None:
        self.browser.send("Target.disposeBrowserContext", {"browserContextId": self.context})
        self.browser._events = [e for e in self.browser._events if e.get("sessionId") != self.session]


def measure(page_path: Path, browser: Browser, width: int = 1200) -> dict:
    """Open ``page_path`` with the measuring script in ``browser`` at ``width`` x 900 px (module docstring)."""
    with browser.open(Path(page_path).resolve().as_uri(), width, 900, 20000, MEASURE) as page:
        found = page.evaluate("(document.getElementById('measure') || {}).textContent")
    assert found, browser._fail("no measurement in the page")
    return json.loads(found)


def screenshot(page_path: Path, out: Path, browser: Browser, width: int = 1200, height: int = 3000,
               fragment: str = "") -> Path:
    """A PNG of the top ``height`` px of the page (URL + ``fragment``) at ``width`` px, after its scripts ran."""
    out.parent.mkdir(parents=True, exist_ok=True)
    with browser.open(Path(page_path).resolve().as_uri() + fragment, width, height, 8000) as page:
        out.write_bytes(base64.b64decode(page.send("Page.captureScreenshot", {"format": "png"})["data"]))
    return out


#: skip a test when there is no Chromium
needs_chromium = pytest.mark.skipif(chromium() is None, reason="Chromium not installed (.ci/run installs it)")


def output_dir() -> Path:
    """The screenshots' folder: ``$TUNER_TEST_OUTPUT/browser/`` (default ``test-output/browser/`` in the
    repository)."""
    root = Path(os.environ.get("TUNER_TEST_OUTPUT", Path(__file__).resolve().parents[2] / "test-output"))
    out = root / "browser"
    out.mkdir(parents=True, exist_ok=True)
    return out
