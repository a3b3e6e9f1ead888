"""The HTML reports (``--html``) of identify, simulate, diagnose, excite and campaign (issue 37 item 2).

Each command runs once on a small synthetic case (the cart-pendulum log of test_figures, the two-link arm's
excitation of test_excitation, a fleet of three arms of fleet_cases), with ``--json``. Then:

* the numbers: every table cell of a page that holds a number names its place in the JSON and its value
  (``data-path``, ``data-value``); each equals what ``--json`` printed (a campaign's rows: results.csv), and the
  text shown is that value formatted; the JSON embedded in the page is ``--json``'s less the run's times;
* the file: self-contained (no ``src``/``href`` to http(s) or any other host, a CSP that forbids requests),
  byte-identical when the command runs again;
* a real browser: Chromium (Debian's package) opens each page headless — no console error or warning, no
  uncaught error, no request outside the file, every plotly figure drawn (``svg.main-svg`` with its traces);
  skipped with the install command where there is no Chromium;
* without plotly, ``--html`` is refused before the work with the install command.
"""

from __future__ import annotations

import contextlib
import csv
import io
import json
import re
import sys
from html.parser import HTMLParser
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("plotly", reason="the HTML reports need plotly: pip install -e '.[html]'")

import browser  # noqa: E402
import fleet_cases  # noqa: E402
import models  # noqa: E402
import test_excitation  # noqa: E402
import symbolic  # noqa: E402
from symbolic import cli, htmlpage  # noqa: E402


def run(*argv: str) -> dict:
    """``symbolic -q ARGV --json`` in this process: its JSON."""
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        code = cli.main(["-q", *argv, "--json"])
    assert code == 0, out.getvalue()[-2000:]
    return json.loads(out.getvalue())


@pytest.fixture(scope="module")
def inputs(tmp_path_factory) -> Path:
    """cart.toml and log.csv (the cart-pendulum moving, Coulomb friction the model lacks, noise), arm.toml and
    exp.toml (test_excitation's declarations), a fleet of three arms (fleet/fleet.toml)."""
    folder = tmp_path_factory.mktemp("html_inputs")
    text = models.cart_pendulum()
    (folder / "cart.toml").write_text(text)
    num = symbolic.numeric_model(symbolic.derive(symbolic.loads(text, "cart_pendulum")))
    t = np.arange(0, 8, 2e-3)
    w = 2 * np.pi * np.array([0.3, 0.7, 1.1])
    a, b = np.array([1, 0.5, 0.3]), np.array([0.6, 0.4, 0.3])
    q = np.column_stack([0.2 * np.sin(np.outer(t, w)) @ a, 0.8 * np.cos(np.outer(t, w)) @ b])
    qd = np.column_stack([0.2 * np.cos(np.outer(t, w)) @ (w * a), -0.8 * np.sin(np.outer(t, w)) @ (w * b)])
    qdd = np.column_stack([-0.2 * np.sin(np.outer(t, w)) @ (w**2 * a), -0.8 * np.cos(np.outer(t, w)) @ (w**2 * b)])
    tau = np.array([num.inverse_dynamics(x, y, z) for x, y, z in zip(q, qd, qdd)])
    tau += 0.3 * np.sign(qd) + np.random.default_rng(0).normal(0, 0.05, tau.shape)
    np.savetxt(folder / "log.csv", np.column_stack([t, q, tau]), delimiter=",", header="t,q_x,q_th,tau_x,tau_th",
               comments="", fmt="%.17g")
    (folder / "arm.toml").write_text(models.arm())
    (folder / "exp.toml").write_text(test_excitation.EXPERIMENT)
    fleet_cases.fleet(folder / "fleet", logs=4, robots=3, seconds=6.0)
    return folder


def commands(i: Path, out: Path) -> dict[str, list[str]]:
    return {
        "identify": ["identify", str(i / "cart.toml"), str(i / "log.csv"), "--html", str(out / "identify" / "report.html")],
        "simulate": ["simulate", str(i / "cart.toml"), str(i / "log.csv"), "--out", str(out / "simulate"), "--html"],
        "diagnose": ["diagnose", str(i / "cart.toml"), str(i / "log.csv"), "--out", str(out / "diagnose"), "--html"],
        "excite": ["excite", str(i / "arm.toml"), "--experiment", str(i / "exp.toml"), "--duration", "3", "--harmonics",
                   "2", "--starts", "1", "--out", str(out / "excite"), "--separate", "Fv1,Fc1", "--html"],
        "campaign": ["campaign", str(i / "fleet" / "fleet.toml"), "--out", str(out / "campaign"), "--workers", "0", "--html"],
    }


class Reports:
    """{command: (its folder, its --json)}, each command run once, when a test first asks for it (so that no
    test's setup carries all five runs)."""

    def __init__(self, inputs: Path, out: Path) -> None:
        self.inputs, self.out, self.done = inputs, out, {}
        (out / "identify").mkdir()

    def __getitem__(self, name: str) -> tuple[Path, dict]:
        if name not in self.done:
            self.done[name] = (self.out / name, run(*commands(self.inputs, self.out)[name]))
        return self.done[name]


@pytest.fixture(scope="module")
def reports(inputs: Path, tmp_path_factory) -> Reports:
    return Reports(inputs, tmp_path_factory.mktemp("html_reports"))


# -- reading a page --------------------------------------------------------------------------------------------


class Cells(HTMLParser):
    """The numeric cells of a page (path, value, text), its src/href attributes, the embedded JSON."""

    def __init__(self) -> None:
        super().__init__()
        self.cells: list[tuple[list, object, float, str]] = []
        self.links: list[str] = []
        self.embedded = ""
        self._cell: tuple[list, object, float] | None = None
        self._text: list[str] = []
        self._json = False

    def handle_starttag(self, tag: str, attrs: list) -> None:
        a = dict(attrs)
        self.links += [a[k] for k in ("src", "href") if a.get(k) is not None]
        if tag == "td" and "data-path" in a:
            self._cell, self._text = (json.loads(a["data-path"]), json.loads(a["data-value"]),
                                      float(a.get("data-scale", 1.0))), []
        self._json = tag == "script" and a.get("id") == htmlpage.RESULT_ID

    def handle_data(self, data: str) -> None:
        if self._cell is not None:
            self._text.append(data)
        if self._json:
            self.embedded += data

    def handle_endtag(self, tag: str) -> None:
        if tag == "td" and self._cell is not None:
            self.cells.append((*self._cell, "".join(self._text)))
            self._cell = None
        self._json = False


def parse(page: Path) -> Cells:
    cells = Cells()
    cells.feed(page.read_text(encoding="utf-8"))
    return cells


def pages(name: str, reports: Reports) -> list[Path]:
    folder, _ = reports[name]
    return sorted(folder.glob("*.html"))


NAMES = ["identify", "simulate", "diagnose", "excite", "campaign"]


# -- the numbers -----------------------------------------------------------------------------------------------


def csv_value(rows: list[dict], row: dict, path: list) -> float:
    """The number of results.csv that a page's cell at ``path`` (under ``rows[i]``) shows."""
    line = next(r for r in rows if r["robot"] == row["robot"] and r["log"] == row["log"])
    if path[0] == "parameters":
        return float(line[f"{path[2]}:{row['parameters'][path[1]]['name']}"])
    if path[0] == "simulation":
        return float(line[f"sim:{path[1]}:{path[2]}"])
    return float(line[path[0]])


@pytest.mark.parametrize("name", NAMES)
def test_the_numbers_are_the_json_s(name: str, reports) -> None:
    folder, printed = reports[name]
    found = pages(name, reports)
    assert found and (folder / "report.html") in found
    if name == "campaign":
        assert len(found) == 1 + 3  # the campaign and one page per robot
        rows = list(csv.DictReader(io.StringIO((folder / "results.csv").read_text())))
    checked = 0
    for page in found:
        cells = parse(page)
        embedded = json.loads(cells.embedded)
        if page.name == "report.html":  # the page's source is --json's dictionary, less the run's times
            expected = htmlpage.stable(printed)
            assert {k: v for k, v in embedded.items() if k != "rows"} == expected
        assert cells.cells, page
        for path, value, scale, text in cells.cells:
            assert htmlpage.lookup(embedded, path) == value, (page.name, path)
            if path[0] == "rows":
                assert value == pytest.approx(csv_value(rows, embedded["rows"][path[1]], path[2:]), rel=0, abs=0), path
            elif name != "campaign" or page.name == "report.html":
                assert htmlpage.lookup(printed, path) == value, (page.name, path)
            else:  # a robot's page: its drifts and outliers are the campaign's
                assert embedded[path[0]][path[1]] in htmlpage.stable(printed)[path[0]], (page.name, path)
            shown = re.sub(r"[^0-9eE.+−-]", "", text.split(" ")[0]).replace("−", "-")
            assert value is None and text == "—" or float(shown) == pytest.approx(value * scale, rel=1e-2, abs=1e-12), \
                (path, text)
            checked += 1
    assert checked >= 10


def test_the_tables_hold_the_named_quantities(reports) -> None:
    """The gap table, the named effects and the parameters with σ are where a reader looks for them."""
    _, diagnosis = reports["diagnose"]
    cells = {tuple(p): v for p, v, _, _ in parse(reports["diagnose"][0] / "report.html").cells}
    assert ("gap_before", "estimation") in cells and ("gap_after", "validation") in cells
    assert diagnosis["found"], "the synthetic log's Coulomb friction is found"
    for k, f in enumerate(diagnosis["found"]):
        for role in f["parameters"]:
            assert ("found", k, "parameters", role) in cells and ("found", k, "evidence", "sigma", role) in cells
    _, identified = reports["identify"]
    cells = {tuple(p) for p, _, _, _ in parse(reports["identify"][0] / "report.html").cells}
    for name in identified["parameters"]:
        assert {("parameters", name, "value"), ("parameters", name, "sigma")} <= cells


# -- the file ---------------------------------------------------------------------------------------------------


@pytest.mark.parametrize("name", NAMES)
def test_the_page_is_one_file(name: str, reports) -> None:
    for page in pages(name, reports):
        text = page.read_text(encoding="utf-8")
        links = parse(page).links
        assert all(not re.match(r"^([a-z]+:)?//", link, re.I) and ":" not in link.split("/")[0] for link in links), links
        assert "Content-Security-Policy" in text and "default-src 'none'" in text
        assert text.count("<div id=\"figure-") == len(set(re.findall(r'<div id="(figure-\d+)"', text)))
        if name == "campaign" and page.name.startswith("robot_"):
            assert 'href="report.html"' in text
    if name == "campaign":
        index = (reports[name][0] / "report.html").read_text()
        assert all(f'href="{p.name}"' in index for p in pages(name, reports) if p.name != "report.html")


@pytest.mark.parametrize("name", NAMES)
def test_a_second_run_writes_the_same_bytes(name: str, inputs: Path, reports, tmp_path: Path) -> None:
    """Fixed figure ids, no date, no run time: the same input gives the same page (a campaign's rerun takes its
    logs from the cache: the counts differ, the pages do not)."""
    out = reports[name][0].parent
    before = {p.name: p.read_bytes() for p in pages(name, reports)}
    run(*commands(inputs, out)[name])
    assert {p.name: p.read_bytes() for p in pages(name, reports)} == before


def test_long_signals_are_drawn_as_their_envelope() -> None:
    t = np.linspace(0, 10, 100_001)
    y = np.sin(t) + np.where(np.abs(t - 3.21) < 1e-3, 5.0, 0.0)  # a burst a few samples wide
    x, kept, reduced = htmlpage.envelope(t, y)
    assert reduced and len(kept) <= htmlpage.MAX_POINTS and np.all(np.diff(x) > 0)
    assert kept.max() == y.max() and kept.min() == y.min()
    assert np.array_equal(htmlpage.envelope(t, y)[1], kept)
    assert htmlpage.envelope(t[:100], y[:100])[2] is False
    assert len(htmlpage.thinned(100_001)) <= htmlpage.MAX_POINTS


def test_without_plotly_html_is_refused_before_the_work(inputs: Path, tmp_path: Path, monkeypatch, capsys) -> None:
    for module in [m for m in sys.modules if m == "plotly" or m.startswith("plotly.")]:
        monkeypatch.delitem(sys.modules, module)
    monkeypatch.setitem(sys.modules, "plotly", None)  # import plotly raises ImportError
    with pytest.raises(symbolic.errors.PlotlyMissing, match=re.escape("pip install 'symbolic[html]'")):
        htmlpage.require()
    for argv in (["identify", str(inputs / "cart.toml"), str(inputs / "log.csv"), "--html", str(tmp_path / "r.html")],
                 ["diagnose", str(inputs / "cart.toml"), str(inputs / "log.csv"), "--out", str(tmp_path / "d"), "--html"]):
        assert cli.main(["-q", *argv]) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and "pip install 'symbolic[html]'" in err, err
    assert list(tmp_path.iterdir()) == []


def test_simulate_html_needs_out(inputs: Path, capsys) -> None:
    assert cli.main(["-q", "simulate", str(inputs / "cart.toml"), str(inputs / "log.csv"), "--html"]) == 2
    assert "--out" in capsys.readouterr().err


# -- a real browser -----------------------------------------------------------------------------------------------


@pytest.mark.parametrize("name", NAMES)
def test_chromium_draws_every_figure_without_error_or_request(name: str, reports, tmp_path: Path) -> None:
    browser.chromium()
    found = pages(name, reports)
    if name == "campaign":  # the campaign's page and one robot's (the others are built alike)
        found = [p for p in found if p.name in ("report.html", "robot_r02.html")]
    for page in found:
        seen = browser.check(page, tmp_path)
        assert seen["log"] == [], (page.name, seen["log"])
        assert seen["resources"] == [], (page.name, seen["resources"])
        expected = len(re.findall(r'<div id="figure-\d+"', page.read_text(encoding="utf-8")))
        assert expected and len(seen["figures"]) == expected, page.name
        for figure in seen["figures"]:
            assert figure["svg"] >= 1 and figure["traces"] >= 1 and figure["height"] > 100, (page.name, figure)


def test_the_browser_check_sees_an_error_and_a_request(tmp_path: Path) -> None:
    """The check itself: a page that logs an error, throws, and asks for a script elsewhere is caught."""
    browser.chromium()
    page = tmp_path / "bad.html"
    page.write_text("<!DOCTYPE html><html><head><meta charset=\"utf-8\">"
                    f"<meta http-equiv=\"Content-Security-Policy\" content=\"{htmlpage.CSP}\"></head><body>"
                    "<div class=\"plotly-graph-div\" id=\"figure-1\"></div>"
                    "<script src=\"https://example.com/plotly.js\"></script>"
                    "<script>console.error('drawn badly'); undefinedFunction();</script></body></html>")
    seen = browser.check(page, tmp_path)
    text = "\n".join(seen["log"])
    assert "console.error: drawn badly" in text and "undefinedFunction" in text, text
    assert "csp: script-src-elem https://example.com/plotly.js" in text, text  # the page's policy refused it
    assert seen["resources"] == ["https://example.com/plotly.js"]  # and the recorder saw it asked for
    assert seen["figures"] == [{"id": "figure-1", "svg": 0, "traces": 0, "points": 0, "width": seen["figures"][0]["width"],
                                "height": 0}]


def test_identify_html_names_a_file_in_an_existing_folder(inputs: Path, tmp_path: Path, capsys) -> None:
    """Checked before the work: a folder, or a file in a folder that does not exist, is one line, exit 2."""
    for target, says in ((tmp_path, "name the HTML file"), (tmp_path / "missing" / "r.html", "does not exist")):
        assert cli.main(["-q", "identify", str(inputs / "cart.toml"), str(inputs / "nothing.csv"), "--html", str(target)]) == 2
        assert says in capsys.readouterr().err
