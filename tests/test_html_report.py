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


# -- the diagnose page's other sections, the response-alone page, a bag's alignment (issue 37's leftovers) --------
#
# Each case runs the command line once (module fixtures) with --json; its page is checked like the five above: every
# number equals --json's, the embedded JSON is --json's less the run's times, Chromium draws every figure without an
# error or a request. And report.md shows the same values: the test formats a few of the JSON's numbers as report.md
# does and finds them there, so a page and a report that drifted apart fail.


def check_page(page: Path, printed: dict) -> dict[tuple, object]:
    """The numbers of ``page`` checked against ``printed`` (--json); ``{path: value}`` of its numeric cells."""
    cells = parse(page)
    assert json.loads(cells.embedded) == htmlpage.stable(printed)
    for path, value, scale, text in cells.cells:
        assert htmlpage.lookup(printed, path) == value, path
        shown = re.sub(r"[^0-9eE.+−-]", "", text.split(" ")[0]).replace("−", "-")
        assert value is None and text == "—" or float(shown) == pytest.approx(value * scale, rel=1e-2, abs=1e-12), \
            (path, text)
    return {tuple(p): v for p, v, _, _ in cells.cells}


def check_in_chromium(page: Path, work: Path) -> int:
    """``page`` opened in headless Chromium: no console error, no request, every figure drawn; how many figures."""
    browser.chromium()
    seen = browser.check(page, work)
    assert seen["log"] == [] and seen["resources"] == [], seen
    expected = len(re.findall(r'<div id="figure-\d+"', page.read_text(encoding="utf-8")))
    assert len(seen["figures"]) == expected
    for figure in seen["figures"]:
        assert figure["svg"] >= 1 and figure["traces"] >= 1 and figure["height"] > 100, figure
    return expected


@pytest.fixture(scope="module")
def response_case(tmp_path_factory) -> tuple[Path, dict]:
    """diagnose --simulate on the axis whose force is logged 3 samples late (test_response's quick case): the search
    judged on the response names delay(q)."""
    from reference_integrator import write_axis_experiment

    folder = tmp_path_factory.mktemp("html_response")
    write_axis_experiment(folder, counts=2**16, seconds=2.0, force_noise=0.02, log_delay=3)
    (folder / "axis.toml").write_text(models.axis(), encoding="utf-8")
    return folder / "out", run("diagnose", str(folder / "axis.toml"), str(folder / "axis.experiment.toml"), "--simulate",
                               "--effects", "viscous,delay", "--out", str(folder / "out"), "--html")


def test_the_response_search_is_on_the_page(response_case, tmp_path: Path) -> None:
    folder, printed = response_case
    cells = check_page(folder / "report.html", printed)
    response = printed["response"]
    assert [n["label"] for n in response["named"]] == ["delay(q)"]
    for role in ("estimation", "validation"):
        for signal in ("force", "position"):
            for side in ("before", "after"):
                assert ("response", side, role, signal, "q") in cells
    assert ("response", "named", 0, "parameters", "delay") in cells
    assert ("response", "named", 0, "held_out_gain") in cells
    (sigma,) = response["named"][0]["sigmas"]
    assert ("response", "named", 0, "sigmas", sigma) in cells
    page = (folder / "report.html").read_text(encoding="utf-8")
    assert "tau_q = { delay = 2.97" in page  # the experiment lines to declare
    report = (folder / "report.md").read_text(encoding="utf-8")
    for side in ("before", "after"):  # report.md's table shows the numbers the page shows
        assert f"{response[side]['validation']['force']['q']:.4g}" in report
    assert check_in_chromium(folder / "report.html", tmp_path) >= 4


@pytest.fixture(scope="module")
def elastic_case(tmp_path_factory) -> tuple[Path, dict]:
    """diagnose on the geared joint logged by both encoders (test_joint_elasticity's case, 3 s): the two-encoder
    test names the joint's elasticity; the patched model has a mode the rigid one lacks."""
    import elastic_reference as truth

    folder = tmp_path_factory.mktemp("html_elastic")
    experiment = truth.write_joint_experiment(folder, seconds=3.0)
    (folder / "joint.toml").write_text(truth.model_text(), encoding="utf-8")
    return folder / "out", run("diagnose", str(folder / "joint.toml"), str(experiment), "--out", str(folder / "out"),
                               "--html")


@pytest.mark.slow
def test_joint_elasticity_and_the_modes_are_on_the_page(elastic_case, tmp_path: Path) -> None:
    folder, printed = elastic_case
    cells = check_page(folder / "report.html", printed)
    (test,) = printed["joint_elasticity"]
    assert test["named"]
    for path in (("values", "stiffness"), ("sigmas", "stiffness"), ("values", "motor_inertia"),
                 ("held_out_error_percent", "rigid"), ("held_out_error_percent", "elastic"), ("gain",), ("link_mode_hz",)):
        assert ("joint_elasticity", 0, *path) in cells, path
    modes = printed["modes"]
    assert modes["after"] and ("modes", "after", 0, "frequency_hz") in cells and ("modes", "after", 0, "damping_ratio") in cells
    for side in ("before", "after"):
        for k in range(len(modes["closed_loop"][side])):
            assert ("modes", "closed_loop", side, k, "frequency_hz") in cells
    for k, finding in enumerate(printed["data_findings"]):  # the gaps with the force as logged and held
        assert ("data_findings", k, "gap_validation", "as_logged") in cells
        if finding.get("patched"):
            assert ("data_findings", k, "patched", "gap_validation", "held_force") in cells
    report = (folder / "report.md").read_text(encoding="utf-8")
    assert f"{test['held_out_error_percent']['elastic']:.4g}" in report
    assert f"{modes['after'][0]['frequency_hz']:.4g} Hz" in report
    check_in_chromium(folder / "report.html", tmp_path)


@pytest.fixture(scope="module")
def alone_case(tmp_path_factory) -> tuple[Path, dict]:
    """diagnose on the elastic joint's model (k 1.7× the truth's) with the motor encoder alone (test_unmeasured's
    case, 1.5 s): judged on the response alone, correction(k) named."""
    import elastic_reference as truth

    folder = tmp_path_factory.mktemp("html_alone")
    experiment = truth.motor_encoder_only(truth.write_joint_experiment(folder, seconds=1.5))
    (folder / "elastic.toml").write_text(truth.elastic_model_text(k=1.7 * truth.TRUTH["k"]), encoding="utf-8")
    return folder / "out", run("diagnose", str(folder / "elastic.toml"), str(experiment), "--out", str(folder / "out"),
                               "--html")


@pytest.mark.slow
def test_the_response_alone_has_its_page(alone_case, tmp_path: Path) -> None:
    folder, printed = alone_case
    assert printed["judged_on"] == "response"
    assert not any("no HTML page" in n for n in printed["notes"])
    cells = check_page(folder / "report.html", printed)
    for c in printed["measured"]:
        for signal in printed["before"]["validation"]:
            for side in ("before", "after"):
                for role in ("estimation", "validation"):
                    assert (side, role, signal, c) in cells
    corrections = printed["response"]["corrections"]
    assert [c["label"] for c in corrections] == ["correction(k)"]
    assert {("response", "corrections", 0, "value"), ("response", "corrections", 0, "sigma"),
            ("response", "corrections", 0, "idim_ls")} <= set(cells)
    assert ("modes", "before", 0, "frequency_hz") in cells and ("modes", "after", 0, "frequency_hz") in cells
    tried = [(k, i, j) for k, round_ in enumerate(printed["response"]["rounds"]) for i, j in enumerate(round_)
             if "verdict" in j]
    assert tried, "the search tried candidates it did not name"
    for k, i, j in tried:  # every candidate tried, its held-out gain and each value fitted
        assert ("response", "rounds", k, i, "held_out_gain") in cells
        for name, value in j["parameters"].items():
            assert ("response", "rounds", k, i, "parameters", name) in cells or not isinstance(value, (int, float))
    report = (folder / "report.md").read_text(encoding="utf-8")
    assert f"{printed['after']['validation']['force']['q']:.4g}" in report
    figures = check_in_chromium(folder / "report.html", tmp_path)
    assert figures == 3 * len(printed["measured"])  # position, force, the force error's spectrum


def test_a_second_run_of_the_response_page_writes_the_same_bytes(response_case) -> None:
    folder, _ = response_case
    before = (folder / "report.html").read_bytes()
    run("diagnose", str(folder.parent / "axis.toml"), str(folder.parent / "axis.experiment.toml"), "--simulate",
        "--effects", "viscous,delay", "--out", str(folder), "--html")
    assert (folder / "report.html").read_bytes() == before


@pytest.fixture(scope="module")
def bag_case(tmp_path_factory) -> tuple[Path, dict[str, dict]]:
    """identify, simulate and diagnose of the two-link arm's MCAP bag with 20 joint states lost (test_bags's
    case): {command: its --json}, the pages in the folder."""
    pytest.importorskip("mcap", reason="the bag readers: pip install -e '.[bags]'")
    import test_bags

    folder = tmp_path_factory.mktemp("html_bag")
    arm = symbolic.derive(symbolic.loads(models.arm(), "arm"))
    bag = test_bags.small_arm_bag(arm, folder, drop=slice(400, 420), seconds=2.0)
    spec = test_bags.experiment(folder, bag)
    (folder / "arm.toml").write_text(models.arm(), encoding="utf-8")
    model = str(folder / "arm.toml")
    with pytest.warns(symbolic.ModelWarning):
        printed = {"identify": run("identify", model, str(spec), "--html", str(folder / "identify.html")),
                   "simulate": run("simulate", model, str(spec), "--out", str(folder / "simulate"), "--html"),
                   "diagnose": run("diagnose", model, str(spec), "--out", str(folder / "diagnose"), "--html")}
    return folder, printed


@pytest.mark.parametrize("name", ["identify", "simulate", "diagnose"])
def test_the_bags_alignment_is_on_every_page(name: str, bag_case, tmp_path: Path) -> None:
    folder, printed = bag_case
    page = folder / "identify.html" if name == "identify" else folder / name / "report.html"
    cells = check_page(page, printed[name])
    at = ("alignment", "estimation") if name == "diagnose" else ("alignment",)
    report = htmlpage.lookup(printed[name], at)
    joint = next(k for k, t in enumerate(report["topics"]) if t["topic"] == "/joint_states")
    assert report["topics"][joint]["gaps"][0]["missing"] == 20
    assert cells[(*at, "topics", joint, "gaps", 0, "missing")] == 20
    assert {(*at, "samples"), (*at, "rate")} <= set(cells)
    for k, t in enumerate(report["topics"]):
        assert {(*at, "topics", k, "messages"), (*at, "topics", k, "rate"), (*at, "topics", k, "dropped", "before")} \
            <= set(cells)
    if name == "diagnose":  # report.md: the same table, from the same dictionary
        text = (folder / name / "report.md").read_text(encoding="utf-8")
        assert "### The bag's topics aligned" in text
        gap = report["topics"][joint]["gaps"][0]
        assert f"| `/joint_states` | {gap['t']:.6g} s | {gap['length']:.3g} s | 20 |" in text
        assert f"| `/joint_states` | sensor_msgs/msg/JointState | {report['topics'][joint]['messages']} |" in text
    check_in_chromium(page, tmp_path)


def test_figure_data_are_float32_typed_arrays_without_the_template() -> None:
    """Page size (issue 37): a figure's values are rounded to 6 digits and carried as base64 float32 typed arrays,
    and plotly's template is not expanded into each figure; decoded, the values are the rounded ones."""
    import base64

    page = htmlpage.Page("t", {"a": 1}, "symbolic test")
    t = np.linspace(0.0, 2.0, 1001)
    y = np.sin(7 * t) * 123.456789
    page.figure("f", [htmlpage.line(t, y, "y")], x="t", y="y")
    text = page.render()
    call = re.search(r'Plotly\.newPlot\(\s*"figure-1",\s*(\[.*?\]),\s*(\{.*\}),\s*\{"displaylogo"', text, re.S)
    data, layout = json.loads(call.group(1)), json.loads(call.group(2))
    for axis, values in (("x", t), ("y", y)):
        packed = data[0][axis]
        assert packed["dtype"] == "f4", packed
        decoded = np.frombuffer(base64.b64decode(packed["bdata"]), dtype="<f4")
        expected = np.array(htmlpage.rounded(values), dtype=np.float32)
        assert np.array_equal(decoded, expected)
        assert np.allclose(decoded, values, rtol=1e-5, atol=0)
    assert len(json.dumps(layout.get("template", {}))) < 100, layout.get("template")
    assert layout["plot_bgcolor"] == "white"
    # about 5.3 characters a value (6.5 with the "/" plotly writes as \\u002f), not 9 or so as decimal text
    assert len(call.group(1)) < 1001 * 2 * 7


@pytest.mark.slow
def test_one_encoder_elasticity_is_on_the_page(tmp_path: Path) -> None:
    """The geared joint seen by its motor encoder alone (test_joint_elasticity's case, 3 s): joint_elasticity (one
    encoder) is found, and its values with σ are in the page's joint elasticity section."""
    import elastic_reference as truth

    experiment = truth.write_joint_experiment(tmp_path, seconds=3.0)
    experiment.write_text(experiment.read_text().replace('ql_q = "ql_q"\n', ""))
    (tmp_path / "joint.toml").write_text(truth.model_text(), encoding="utf-8")
    printed = run("diagnose", str(tmp_path / "joint.toml"), str(experiment), "--out", str(tmp_path / "out"), "--html")
    (k,) = [k for k, f in enumerate(printed["found"]) if f.get("variant") == "one_encoder"]
    page = tmp_path / "out" / "report.html"
    cells = check_page(page, printed)
    text = page.read_text(encoding="utf-8")
    assert "<h3>One encoder</h3>" in text
    for role in printed["found"][k]["parameters"]:
        assert ("found", k, "parameters", role) in cells
    check_in_chromium(page, tmp_path)
