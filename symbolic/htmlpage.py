"""One self-contained HTML page of a report (``--html``): the result's tables and interactive plotly figures.

plotly is optional (``pip install 'symbolic[html]'``), imported only here when a page is asked for;
without it :func:`require` raises :class:`PlotlyMissing` naming that command. The commands call it
before their work, so a missing plotly costs nothing.

* **One source.** A page is built from the dictionary the command prints with ``--json`` (the object
  report.md is written from), never from numbers computed again. That dictionary is embedded whole
  (``<script type="application/json" id="symbolic-result">``, shown in the page's last section) less the
  keys that describe the run rather than the result (:data:`VOLATILE`: run times, cache counts), its keys
  sorted (a result read back from a cache comes with its keys in another order); every
  number a table shows is a :class:`Cell` carrying its JSON path and exact value
  (``data-path='["gap_before","estimation"]' data-value="12.5"``), so a test parses the page and compares
  each with ``--json``. The figures draw the result's signals (measured, simulated, residuals), which the
  JSON does not hold.
* **Self-contained.** plotly.js (plotly's own bundle, what ``include_plotlyjs=True`` inlines) is inlined once
  in ``<head>``, every figure's data inline; a Content-Security-Policy ``<meta>`` (``default-src 'none'``)
  forbids every request, so the page loads nothing from outside the file even if a script tried. Links
  between the pages of a campaign are relative (sibling files).
* **Deterministic.** Fixed figure ids (``figure-1``, ``figure-2``, … in page order), no date, no run time,
  figure values rounded to 6 significant digits: the same result with the same plotly gives the same bytes.
* **Small figures.** plotly.js (4.8 MB, the one bundle the plotly package ships) is most of a page; the figures'
  values are carried as float32 typed arrays (:func:`packed`) and plotly's template is written out as its few
  colours (:data:`LOOK`) instead of expanded into every figure.
* **Long signals.** A line of more than :data:`MAX_POINTS` samples is drawn as the minimum and the maximum of
  each of ``MAX_POINTS/2`` runs of consecutive samples, in time order: the envelope, so peaks and bursts stay
  visible at any zoom (:func:`envelope`); a cloud of points (residual against velocity) keeps every k-th sample,
  k = ⌈n/MAX_POINTS⌉ (:func:`thinned`). Each figure's caption says when its signals were so reduced.
"""

from __future__ import annotations

import html
import json
import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from symbolic.errors import PlotlyMissing
from symbolic.version import __version__

INSTALL = "pip install 'symbolic[html]'"
MISSING = f"--html needs plotly, which is not installed ({INSTALL})"
MAX_POINTS = 4000
"""Samples drawn per trace at most (:func:`envelope`, :func:`thinned`)."""
VOLATILE = frozenset({"timings", "seconds", "cpu_seconds", "computed", "cached", "files", "figures"})
"""Keys left out of the embedded result: how long the run took, what the cache held and the files written
describe the run, not the result, and would make two runs' pages differ."""
LOOK = {"template": "none", "plot_bgcolor": "white", "paper_bgcolor": "white", "font": {"color": "#2a3f5f"},
        "colorway": ["#636efa", "#EF553B", "#00cc96", "#ab63fa", "#FFA15A", "#19d3f3", "#FF6692", "#B6E880"]}
AXIS = {"gridcolor": "#EBF0F8", "linecolor": "#EBF0F8", "zerolinecolor": "#EBF0F8", "zerolinewidth": 2,
        "automargin": True}
"""The look of plotly's ``plotly_white`` template, written out: the template itself, which plotly.py expands
into every figure's JSON (about 7 kB a figure), is left out (``"none"``)."""
SIGNIFICANT = 6
RESULT_ID = "symbolic-result"
REPORT = "report.html"
"""The page's name in an output folder (beside report.md)."""
CSP = ("default-src 'none'; script-src 'unsafe-inline'; style-src 'unsafe-inline'; "
       "img-src data:; font-src data:")
STYLE = """
body { font-family: system-ui, sans-serif; margin: 1.5em auto; max-width: 1100px; padding: 0 1em; color: #222; }
table { border-collapse: collapse; margin: 0.6em 0 1.2em; font-size: 0.92em; }
th, td { border: 1px solid #ccc; padding: 0.25em 0.6em; text-align: left; vertical-align: top; }
th { background: #f2f2f2; } td.n { text-align: right; font-variant-numeric: tabular-nums; }
.figure { border: 1px solid #e4e4e4; margin: 0.8em 0 1.6em; } .caption { font-size: 0.85em; color: #555; margin: 0.3em 0.6em; }
footer { margin-top: 2em; font-size: 0.85em; color: #666; } pre { font-size: 0.8em; overflow-x: auto; }
"""


def require() -> None:
    """:class:`PlotlyMissing` (naming the install command) unless plotly can be imported."""
    try:
        import plotly.graph_objects  # noqa: F401
        import plotly.offline  # noqa: F401
    except ImportError:
        raise PlotlyMissing(MISSING) from None


def stable(result: Mapping[str, Any]) -> dict[str, Any]:
    """``result`` without the :data:`VOLATILE` keys, at any depth; values not finite become ``None`` (strict JSON)."""
    def clean(x: Any) -> Any:
        if isinstance(x, Mapping):
            return {str(k): clean(v) for k, v in x.items() if k not in VOLATILE}
        if isinstance(x, (list, tuple)):
            return [clean(v) for v in x]
        if type(x).__module__ == "numpy" and hasattr(x, "item"):
            x = x.item()
        if isinstance(x, float) and not math.isfinite(x):
            return None
        return x

    return clean(result)


def lookup(result: Any, path: Sequence[str | int]) -> Any:
    """The value at ``path`` (keys and list indices) of ``result``."""
    for key in path:
        result = result[key]
    return result


@dataclass(frozen=True)
class Cell:
    """A number of the result in a table: its text, and where it is in the JSON with its exact value."""

    text: str
    path: tuple[str | int, ...]
    value: float | int | None
    scale: float = 1.0
    """The text shows ``value × scale`` (100: a fraction shown in %)."""


def number(result: Mapping[str, Any], *path: str | int, digits: int = 4, unit: str = "", signed: bool = False,
           scale: float = 1.0) -> Cell:
    """The number at ``path`` of ``result`` as a :class:`Cell` (``digits`` significant; ``—`` for ``None``);
    ``scale``: the text shows the value times it (100 with ``unit="%"``: a fraction in percent)."""
    value = lookup(result, path)
    if value is None:
        return Cell("—", tuple(path), None, scale)
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise TypeError(f"{list(path)} is not a number: {value!r}")
    text = f"{value * scale:{'+' if signed else ''}.{digits}g}" + (f" {unit}" if unit else "")
    return Cell(text, tuple(path), value, scale)


def rounded(values: Any) -> list[float | None]:
    """``values`` as a list of floats to :data:`SIGNIFICANT` digits (``None`` where not finite)."""
    array = np.asarray(values, dtype=float).ravel()
    return [float(f"{v:.{SIGNIFICANT}g}") if math.isfinite(v) else None for v in array.tolist()]


def packed(values: Any) -> np.ndarray:
    """``values`` as the figures carry them: :func:`rounded` to :data:`SIGNIFICANT` digits, then float32 (NaN where
    not finite), which plotly writes as a base64 typed array (``{"dtype": "f4", "bdata": ...}``): 5.3 characters
    a value instead of about 10 as decimal text, and float32's 7 digits keep the 6 rounded to."""
    return np.array([np.nan if v is None else v for v in rounded(values)], dtype=np.float32)


def envelope(x: Any, y: Any, limit: int = MAX_POINTS) -> tuple[np.ndarray, np.ndarray, bool]:
    """``x, y`` with at most ``limit`` points: the minimum and maximum of each of ``limit/2`` runs of
    consecutive samples, in their order (module docstring); and whether it was reduced."""
    x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
    n = len(y)
    if n <= limit:
        return x, y, False
    edges = np.linspace(0, n, limit // 2 + 1).astype(int)
    keep: list[int] = []
    finite = np.where(np.isfinite(y), y, np.nan)
    for start, stop in zip(edges[:-1], edges[1:]):
        run = finite[start:stop]
        if stop <= start or np.all(np.isnan(run)):
            continue
        low, high = start + int(np.nanargmin(run)), start + int(np.nanargmax(run))
        keep += sorted({low, high})
    index = np.asarray(keep, dtype=int)
    return x[index], y[index], True


def thinned(n: int, limit: int = MAX_POINTS) -> np.ndarray:
    """Indices of every k-th of ``n`` samples, k = ⌈n/limit⌉ (module docstring)."""
    return np.arange(0, n, max(1, math.ceil(n / limit)))


def line(x: Any, y: Any, name: str, *, dash: str | None = None, width: float = 1.2, color: str | None = None,
         limit: int = MAX_POINTS) -> dict[str, Any]:
    """A line trace (its envelope beyond ``limit`` samples)."""
    x, y, reduced = envelope(x, y, limit)
    trace: dict[str, Any] = {"type": "scatter", "mode": "lines", "name": name, "x": packed(x), "y": packed(y),
                             "line": {"width": width, **({"dash": dash} if dash else {}), **({"color": color} if color else {})}}
    return {**trace, "_reduced": "envelope"} if reduced else trace


def points(x: Any, y: Any, name: str, *, size: float = 3, color: str | None = None, error: Any = None,
           limit: int = MAX_POINTS) -> dict[str, Any]:
    """A cloud of points (every k-th beyond ``limit``); ``error``: symmetric error bars (σ)."""
    x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
    index = thinned(len(y), limit)
    trace: dict[str, Any] = {"type": "scatter", "mode": "markers", "name": name, "x": packed(x[index]),
                             "y": packed(y[index]), "marker": {"size": size, **({"color": color} if color else {})}}
    if error is not None:
        trace["error_y"] = {"type": "data", "array": packed(np.asarray(error, dtype=float)[index]), "visible": True}
    return {**trace, "_reduced": "thinned"} if len(index) < len(y) else trace


def bars(x: Sequence[str], y: Any, name: str) -> dict[str, Any]:
    return {"type": "bar", "name": name, "x": list(x), "y": packed(y)}


def band(start: float, stop: float, label: str, color: str = "rgba(214,39,40,0.15)") -> dict[str, Any]:
    """A shaded interval of x (a layout shape): a worst window, a border left out."""
    return {"type": "rect", "xref": "x", "yref": "paper", "x0": float(f"{start:.{SIGNIFICANT}g}"),
            "x1": float(f"{stop:.{SIGNIFICANT}g}"), "y0": 0, "y1": 1, "fillcolor": color, "line": {"width": 0},
            "layer": "below", "name": label}


class Page:
    """An HTML page under construction: headings, paragraphs, tables of :class:`Cell`, figures (module docstring)."""

    def __init__(self, title: str, result: Mapping[str, Any], command: str) -> None:
        self.title = title
        self.result = stable(result)
        self.command = command
        self.parts: list[str] = []
        self.figures = 0

    def heading(self, text: str, level: int = 2) -> None:
        self.parts.append(f"<h{level}>{html.escape(text)}</h{level}>")

    def paragraph(self, text: str) -> None:
        self.parts.append(f"<p>{html.escape(text)}</p>")

    def items(self, texts: Iterable[str]) -> None:
        texts = list(texts)
        if texts:
            self.parts.append("<ul>" + "".join(f"<li>{html.escape(t)}</li>" for t in texts) + "</ul>")

    def code(self, lines: Iterable[str]) -> None:
        """Lines to copy as they are (an experiment file's lines), preformatted."""
        self.parts.append("<pre>" + html.escape("\n".join(lines)) + "</pre>")

    def link(self, text: str, href: str, after: str = "") -> None:
        """A link to a sibling page of the same folder (relative: no request outside the report's files)."""
        if "://" in href or href.startswith("//"):
            raise ValueError(f"a report links its own files only, not {href!r}")
        self.parts.append(f'<p><a href="{html.escape(href)}">{html.escape(text)}</a>{html.escape(after)}</p>')

    def table(self, header: Sequence[str], rows: Iterable[Sequence[Any]]) -> None:
        """A table; a :class:`Cell` is a number of the result (its path and value in data attributes)."""
        out = ["<table><thead><tr>" + "".join(f"<th>{html.escape(h)}</th>" for h in header) + "</tr></thead><tbody>"]
        for row in rows:
            out.append("<tr>" + "".join(_cell(c) for c in row) + "</tr>")
        out.append("</tbody></table>")
        self.parts.append("".join(out))

    def figure(self, title: str, traces: Sequence[Mapping[str, Any]], *, x: str, y: str, log_y: bool = False,
               height: int = 420, shapes: Sequence[Mapping[str, Any]] = (), caption: str = "",
               categories: bool = False, y2: str | None = None) -> None:
        """An interactive figure (zoom, pan, hover), drawn from ``traces`` (:func:`line`, :func:`points`,
        :func:`bars`); the caption says how long signals were reduced. ``y2``: the title of a second y axis, on
        the right, for the traces with ``"yaxis": "y2"`` (a difference much smaller than the signals)."""
        import plotly.graph_objects as go

        self.figures += 1
        ways = {t.get("_reduced") for t in traces} - {None}
        data = [{k: v for k, v in t.items() if k != "_reduced"} for t in traces]
        notes = [caption] if caption else []
        if "envelope" in ways:
            notes.append(f"Lines of more than {MAX_POINTS} samples are drawn as the minimum and maximum of each run of "
                         f"consecutive samples ({MAX_POINTS // 2} runs): the envelope, peaks kept.")
        if "thinned" in ways:
            notes.append(f"Clouds of more than {MAX_POINTS} points show every k-th sample, k = ⌈n/{MAX_POINTS}⌉.")
        layout = {"title": {"text": html.escape(title), "font": {"size": 14}}, "height": height, **LOOK,
                  "margin": {"l": 70, "r": 20, "t": 50, "b": 55},
                  "xaxis": {**AXIS, "title": {"text": html.escape(x)}, **({"type": "category"} if categories else {})},
                  "yaxis": {**AXIS, "title": {"text": html.escape(y)}, **({"type": "log"} if log_y else {})},
                  "legend": {"orientation": "h", "y": -0.2}, "hovermode": "closest", "shapes": list(shapes)}
        if y2 is not None:
            layout["yaxis2"] = {**AXIS, "title": {"text": html.escape(y2)}, "overlaying": "y", "side": "right", "showgrid": False}
            layout["margin"]["r"] = 70
        figure = go.Figure(data=data, layout=layout)
        div = figure.to_html(full_html=False, include_plotlyjs=False, div_id=f"figure-{self.figures}",
                             config={"displaylogo": False, "responsive": True}, default_height=f"{height}px")
        caption_html = f'<div class="caption">{html.escape(" ".join(notes))}</div>' if notes else ""
        self.parts.append(f'<div class="figure">{div}{caption_html}</div>')

    def render(self) -> str:
        """The whole page (module docstring)."""
        script = ""
        if self.figures:
            from plotly.offline import get_plotlyjs

            script = ("<script type=\"text/javascript\">window.PlotlyConfig = {MathJaxConfig: 'local'};</script>\n"
                      f"<script type=\"text/javascript\">{get_plotlyjs()}</script>\n")
        data = json.dumps(self.result, indent=1, ensure_ascii=False, allow_nan=False, sort_keys=True).replace("</", "<\\/")
        return (
            "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n"
            f"<meta http-equiv=\"Content-Security-Policy\" content=\"{CSP}\">\n"
            "<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n"
            f"<title>{html.escape(self.title)}</title>\n<style>{STYLE}</style>\n{script}</head>\n<body>\n"
            f"<h1>{html.escape(self.title)}</h1>\n" + "\n".join(self.parts) + "\n"
            "<h2>The result as JSON</h2>\n<details><summary>What <code>" + html.escape(self.command) +
            " --json</code> prints, less the run's times and file list; every number above is read from it."
            "</summary><pre id=\"symbolic-json\"></pre></details>\n"
            f"<script type=\"application/json\" id=\"{RESULT_ID}\">{data}</script>\n"
            "<script type=\"text/javascript\">document.getElementById(\"symbolic-json\").textContent = "
            f"document.getElementById(\"{RESULT_ID}\").textContent;</script>\n"
            f"<footer>Written by symbolic {html.escape(__version__)}; one file, no request outside it.</footer>\n"
            "</body>\n</html>\n")


def _cell(c: Any) -> str:
    if isinstance(c, Cell):
        value = "null" if c.value is None else repr(c.value)
        path = html.escape(json.dumps(list(c.path), ensure_ascii=False), quote=True)
        scale = "" if c.scale == 1.0 else f' data-scale="{c.scale!r}"'
        return f'<td class="n" data-path="{path}" data-value="{value}"{scale}>{html.escape(c.text)}</td>'
    return f"<td>{html.escape('' if c is None else str(c))}</td>"



def spectrum_traces(spectra: Mapping[str, tuple[Any, Any]]) -> list[dict[str, Any]]:
    """One line per named ``(frequency, psd)`` (:func:`symbolic.data.filters.spectrum`), where the PSD is positive
    (a log axis has no zero)."""
    out = []
    for name, (f, psd) in spectra.items():
        f, psd = np.asarray(f, dtype=float), np.asarray(psd, dtype=float)
        shown = psd > 0
        out.append(line(f[shown], psd[shown], name if shown.any() else f"{name}: zero residual (nothing to draw)"))
    return out


def alignment(page: Page, r: Mapping[str, Any], key: str = "alignment") -> None:
    """The alignment of the bags a command read (``r[key]``: one :meth:`symbolic.data.bags.Alignment.to_dict`, or
    ``{data set: that}``; nothing when the data were no bag): the time base, and per topic its messages, rate,
    gaps and dropped messages — the table report.md shows (:func:`symbolic.data.bags.markdown_lines`)."""
    found = r.get(key)
    if not found:
        return
    sets = [((key,), found)] if "topics" in found else [((key, role), a) for role, a in found.items() if a]
    page.heading("The bag's topics aligned")
    page.paragraph("Every topic put onto one time base over the interval all of them have messages (docs/data.md, "
                   "\"Alignment\"): each topic's rate between gaps, each gap bridged, and the messages dropped.")
    for at, a in sets:
        role = f" ({at[1]} data)" if len(at) > 1 else ""
        page.paragraph(f"{a.get('file', 'the bag')}{role}: t = 0 at {a['start_ns'] / 1e9:.9f} s of the bag's clock.")
        page.table(["time base", "samples", "rate"],
                   [[a["base"], number(r, *at, "samples", digits=12), number(r, *at, "rate", digits=6, unit="Hz")]])
        page.table(["topic", "type", "messages", "rate", "time", "method", "dropped before the time base",
                    "after it", "with a repeated stamp", "out of order (sorted)"],
                   [[t["topic"], t["type"], number(r, *at, "topics", k, "messages", digits=12),
                     number(r, *at, "topics", k, "rate", digits=6, unit="Hz"), t["stamps"], "/".join(t["methods"]),
                     number(r, *at, "topics", k, "dropped", "before", digits=12),
                     number(r, *at, "topics", k, "dropped", "after", digits=12),
                     number(r, *at, "topics", k, "dropped", "repeated", digits=12),
                     number(r, *at, "topics", k, "out_of_order", digits=12)] for k, t in enumerate(a["topics"])])
        gaps = [[t["topic"], number(r, *at, "topics", k, "gaps", g, "t", digits=6, unit="s"),
                 number(r, *at, "topics", k, "gaps", g, "length", digits=3, unit="s"),
                 number(r, *at, "topics", k, "gaps", g, "missing", digits=12)]
                for k, t in enumerate(a["topics"]) for g in range(len(t["gaps"]))]
        if gaps:
            page.paragraph("Gaps (steps longer than 1.5 median steps), each bridged by its topic's method:")
            page.table(["topic", "at t", "length", "messages missing"], gaps)
        else:
            page.paragraph("No gap in any topic.")
