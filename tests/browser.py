"""A real headless browser (Chromium from the distribution's packages) opening an HTML report, for the tests.

:func:`check` opens an instrumented copy of the page (a recorder script inserted first in ``<head>``: console
errors and warnings, uncaught errors and rejected promises, Content-Security-Policy violations, and after load
every resource the page requested and, per plotly figure, its drawn ``svg.main-svg`` and traces) with
``chromium --headless --dump-dom`` and returns what the recorder wrote into the dumped DOM. The page's own
Content-Security-Policy (``default-src 'none'``) makes any request outside the file a violation, recorded; the
browser runs without network besides (no host resolves, every connection goes to a closed proxy port), so a page
that needed one would miss it.
Tests skip, saying how to install it, where no Chromium is found.
"""

from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
from pathlib import Path

import pytest

NAMES = ("chromium", "chromium-browser", "google-chrome", "chrome")
INSTALL = "apt-get install chromium (Debian's package; .ci/run installs it when apt-get is available)"

RECORDER = """<script>(function () {
  var log = [];
  function put(kind, text) { log.push(kind + ": " + text); }
  ["error", "warn"].forEach(function (level) {
    var original = console[level];
    console[level] = function () { put("console." + level, Array.prototype.join.call(arguments, " ")); return original.apply(console, arguments); };
  });
  window.addEventListener("error", function (e) { put("error", e.message || String(e.target && (e.target.src || e.target.href))); }, true);
  window.addEventListener("unhandledrejection", function (e) { put("unhandledrejection", String(e.reason)); });
  document.addEventListener("securitypolicyviolation", function (e) { put("csp", e.violatedDirective + " " + e.blockedURI); });
  window.addEventListener("load", function () { setTimeout(function () {
    var figures = Array.prototype.map.call(document.querySelectorAll("div.plotly-graph-div"), function (d) {
      return {id: d.id, svg: d.querySelectorAll("svg.main-svg").length, traces: d.querySelectorAll("g.trace").length,
              points: d.querySelectorAll("path.point").length + d.querySelectorAll("path.js-line").length,
              width: d.getBoundingClientRect().width, height: d.getBoundingClientRect().height};
    });
    var out = document.createElement("pre"); out.id = "symbolic-browser-check";
    out.textContent = JSON.stringify({log: log, figures: figures,
      resources: performance.getEntriesByType("resource").map(function (r) { return r.name; })});
    document.body.appendChild(out);
  }, 300); });
})();</script>"""


def chromium() -> str:
    """The browser's path; skips the calling test where there is none."""
    for name in NAMES:
        found = shutil.which(name)
        if found:
            return found
    pytest.skip(f"no headless browser found ({', '.join(NAMES)}): {INSTALL}")


def _run(arguments: list[str], timeout: float = 90) -> subprocess.CompletedProcess:
    home = Path(os.environ.get("TMPDIR", "/tmp"))
    command = [chromium(), "--headless", "--no-sandbox", "--disable-gpu", "--no-first-run", "--no-default-browser-check",
               "--disable-extensions", "--disable-background-networking", "--disable-sync", "--mute-audio",
               "--hide-scrollbars", "--host-resolver-rules=MAP * ~NOTFOUND", "--proxy-server=127.0.0.1:9",
               "--proxy-bypass-list=<-loopback>", *arguments]  # no network: every host unknown, every request refused
    return subprocess.run(command, capture_output=True, text=True, timeout=timeout, env={**os.environ, "HOME": str(home)})


def check(page: Path, work: Path) -> dict:
    """Open an instrumented copy of ``page`` (module docstring); ``{"log", "figures", "resources"}``."""
    text = page.read_text(encoding="utf-8")
    head = text.index("<head>") + len("<head>")
    copy = work / f"checked_{page.name}"
    copy.write_text(text[:head] + RECORDER + text[head:], encoding="utf-8")
    done = _run(["--virtual-time-budget=20000", "--run-all-compositor-stages-before-draw", "--window-size=1280,2000",
                 "--dump-dom", copy.resolve().as_uri()])
    found = re.search(r'<pre id="symbolic-browser-check">(.*?)</pre>', done.stdout, re.S)
    assert found, f"the page did not finish loading in Chromium (rc {done.returncode}): {done.stderr[-2000:]}"
    import html

    return json.loads(html.unescape(found.group(1)))


def screenshot(page: Path, png: Path, height: int = 3000) -> Path:
    """A screenshot of ``page`` (1280 px wide) into ``png``, for a person to look at."""
    _run(["--virtual-time-budget=20000", f"--window-size=1280,{height}", f"--screenshot={png}", page.resolve().as_uri()])
    return png
