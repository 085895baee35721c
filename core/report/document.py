"""The calibration report as data: a summary box, then one section per step, each a list of
blocks (HTML text or a Figure). `render_html` writes it as HTML; the figures' images are drawn
by the app (pyqtgraph) and handed in as `src` strings (data URIs for a self-contained HTML file,
resource names for the printed PDF). No Qt here."""
from __future__ import annotations

import html
import math
from dataclasses import dataclass, field
from typing import Mapping

STYLE = """
body { font-family: sans-serif; font-size: 10pt; color: #202124; }
h1 { font-size: 17pt; margin-bottom: 0.2em; }
h2 { font-size: 13pt; color: #1a73e8; margin-top: 1.0em; margin-bottom: 0.3em; }
table.title td { padding: 1px 18px 1px 0; }
td.label { color: #5f6368; }
h3 { font-size: 10.5pt; margin-top: 0.8em; margin-bottom: 0.2em; }
table.data { border-collapse: collapse; margin: 0.3em 0; }
table.data td, table.data th { padding: 1px 10px 1px 0; text-align: left; vertical-align: top; }
td.n, th.n { text-align: right; }
.grey { color: #80868b; }
.warn { color: #b06000; }
.note { color: #5f6368; font-size: 9pt; }
.verdict { font-size: 12pt; font-weight: bold; }
.caption { color: #5f6368; font-size: 9pt; }
"""

#: series colours, in order (the app draws with these; colour-blind safe: Okabe-Ito)
PALETTE = ("#0072B2", "#D55E00", "#009E73", "#CC79A7", "#E69F00", "#56B4E9", "#000000")


@dataclass
class Figure:
    """One figure: `panels` side by side, each a dict made by `panel()`; `unavailable` says
    why it cannot be drawn for this project (then `panels` is empty). A panel of kind "image"
    also carries the image array (H, W) under "image"."""

    key: str                           # unique in the report; the image's file stem
    title: str
    caption: str
    panels: list[dict] = field(default_factory=list)
    unavailable: str | None = None
    size: tuple[int, int] = (900, 330)  # drawn size in px at 96 dpi (printed 174 × 64 mm, PRINT_SCALE)


def series(name: str, x=None, y=None, *, values=None, color: int | None = None, symbol: str = "o",
           line: bool = False, bars: bool = False) -> dict:
    """One data series of a panel: points (x, y), bars at x of height y, or `values` for a
    histogram. `color` indexes PALETTE."""
    out = {"name": name, "symbol": symbol, "line": line, "bars": bars}
    if color is not None:
        out["color"] = color
    if values is not None:
        out["values"] = [float(v) for v in values]
    if x is not None:
        out["x"] = [float(v) for v in x]
    if y is not None:
        out["y"] = [float(v) for v in y]
    return out


def panel(kind: str, title: str, xlabel: str, ylabel: str, data: list[dict], *, hlines=(), log_y=False,
          equal_aspect=False, bins: int = 20, x_ticks: list | None = None) -> dict:
    """One plot: `kind` "points" (markers/lines/bars from x, y), "histogram" (of each series'
    values, `bins` shared bins), "image" (the panel's "image" array with the series drawn over
    it, in its pixel coordinates, y down) or "matrix" (the panel's "matrix" array, values in
    [-1, 1], in diverging colours with a colour bar; row 0 at the top). `hlines`: (value, label)
    drawn across; labels carry units. `x_ticks`: values, or (value, label) pairs."""
    return {"kind": kind, "title": title, "xlabel": xlabel, "ylabel": ylabel, "series": data,
            "hlines": [(float(v), str(label)) for v, label in hlines], "log_y": log_y,
            "equal_aspect": equal_aspect, "bins": bins, "x_ticks": x_ticks}


@dataclass
class Section:
    title: str
    blocks: list = field(default_factory=list)     # str (HTML) or Figure
    done: bool = True

    def figures(self) -> list[Figure]:
        return [b for b in self.blocks if isinstance(b, Figure)]


@dataclass
class Report:
    title: str
    header: str                        # HTML: the title block (who, course, robot, serial number, date) and a note
    summary: str                       # HTML of the summary box
    sections: list[Section]
    conventions: str = ""              # HTML: units and terms, under the summary box
    problems: list[str] = field(default_factory=list)   # files that could not be read, with why

    def figures(self) -> list[Figure]:
        return [f for s in self.sections for f in s.figures()]

    def not_done(self) -> list[str]:
        return [s.title for s in self.sections if not s.done]


# -- small HTML helpers ------------------------------------------------------------------------
def esc(text) -> str:
    return html.escape(str(text))


def num(value, digits: int = 3, unit: str = "") -> str:
    """A number with fixed decimals (and a unit), '—' for None / NaN / not a number."""
    try:
        v = float(value)
    except (TypeError, ValueError):
        return "—" if value is None else esc(value)
    if math.isnan(v):
        return "—"
    if math.isinf(v):
        return "∞"
    return f"{v:.{digits}f}" + (f" {unit}" if unit else "")


def sig(value, digits: int = 3) -> str:
    """A number with `digits` significant digits ('—' for None / NaN)."""
    try:
        v = float(value)
    except (TypeError, ValueError):
        return "—"
    return "∞" if math.isinf(v) else ("—" if math.isnan(v) else f"{v:.{digits}g}")


def table(header: list[str], rows: list[list], numeric: set[int] = frozenset(), nowrap: set[int] = frozenset()) -> str:
    """An HTML table; cells are HTML already (escape text first); columns in `numeric` right-aligned,
    the cells of columns in `nowrap` never broken across lines."""
    def cell(tag, i, v):
        style = " style='white-space: nowrap'" if i in nowrap and tag == "td" else ""
        return f"<{tag}{style}{' class=n' if i in numeric else ''}>{v}</{tag}>"
    head = "<tr>" + "".join(cell("th", i, esc(h)) for i, h in enumerate(header)) + "</tr>" if header else ""
    body = "".join("<tr>" + "".join(cell("td", i, v) for i, v in enumerate(r)) + "</tr>" for r in rows)
    return f"<table class='data'>{head}{body}</table>"


def pairs_table(rows: list[tuple[str, str]]) -> str:
    """A two-column table of (label, HTML value)."""
    return table([], [[esc(k), v] for k, v in rows])


def side_by_side(headers: list[list[str]], groups: list[list[list]], numeric: set[int] = frozenset()) -> str:
    """Several runs of rows with the same columns next to each other in one table (the left camera,
    right camera and stereo parameters): `headers[k]` over run k, a blank column between runs,
    short runs padded with empty cells; cells never wrap, so keep the runs narrow."""
    width = len(headers[0])
    gap = "<td width='14'></td>"

    def cell(tag, i, v):          # never wrapped: the runs share the width
        return (f"<{tag} style='white-space: nowrap; font-size: 8.5pt; padding: 1px 6px 1px 0'"
                f"{' class=n' if i in numeric else ''}>{v}</{tag}>")

    head = "<tr>" + gap.join("".join(cell("th", i, esc(h)) for i, h in enumerate(header)) for header in headers) + "</tr>"
    body = ""
    for r in range(max((len(g) for g in groups), default=0)):
        runs = [g[r] if r < len(g) else [""] * width for g in groups]
        body += "<tr>" + gap.join("".join(cell("td", i, v) for i, v in enumerate(row)) for row in runs) + "</tr>"
    return f"<table class='data'>{head}{body}</table>"


_GREEK = {"theta": "θ", "alpha": "α", "beta": "β"}


def parameter_name(name: str) -> str:
    """A model parameter's name as printed: J5.theta -> J5.θ, J2.alpha -> J2.α, J2.beta -> J2.β."""
    head, _, tail = str(name).rpartition(".")
    return f"{head}.{_GREEK.get(tail, tail)}" if head else _GREEK.get(tail, tail)


def not_done(what: str) -> str:
    return f"<p class='grey'>Not done ({esc(what)}).</p>"


def unreadable(name: str, message: str) -> str:
    return f"<p class='warn'><b>{esc(name)} cannot be read:</b> {esc(message)}</p>"


# -- HTML ---------------------------------------------------------------------------------------
def _figure_html(fig: Figure, src: str | None, scale: float) -> str:
    if fig.unavailable:          # one sentence on why the figure is missing, no empty frame
        why = fig.unavailable.rstrip(".")
        return f"<p class='grey'>No figure “{esc(fig.title.lower())}”: {esc(why)}.</p>"
    if src is None:
        return f"<p class='grey'>No figure “{esc(fig.title.lower())}”: it could not be drawn.</p>"
    w, h = round(fig.size[0] * scale), round(fig.size[1] * scale)
    # the title goes with the caption under the image: a printed page may break before the image
    return (f"<p><img src='{esc(src)}' width='{w}' height='{h}' alt='{esc(fig.key)}'>"
            f"<br><b>{esc(fig.title)}.</b> <span class='caption'>{esc(fig.caption)}</span></p>")


def _merge_missing(blocks: list) -> list:
    """Consecutive figures missing for the same reason become one sentence naming them all."""
    out: list = []
    run: list[Figure] = []

    def flush():
        if len(run) == 1:
            out.append(run[0])
        elif run:
            names = ", ".join(f"“{f.title.lower()}”" for f in run)
            out.append(f"<p class='grey'>No figures {esc(names)}: {esc(run[0].unavailable.rstrip('.'))}.</p>")
        run.clear()

    for block in blocks:
        if isinstance(block, Figure) and block.unavailable and (not run or run[0].unavailable == block.unavailable):
            run.append(block)
            continue
        flush()
        if isinstance(block, Figure) and block.unavailable:
            run.append(block)
        else:
            out.append(block)
    flush()
    return out


def render_html(report: Report, images: Mapping[str, str] | None = None, *, scale: float = 1.0) -> str:
    """The report as one HTML document, its sections flowing one after the other (a printed page
    breaks where it is full; a figure, being one image, is never split). `images`: figure key ->
    img src; `scale`: figure size on the page / its own size."""
    images = images or {}
    body = [f"<h1>{esc(report.title)}</h1>", report.header,
            "<table width='100%' cellpadding='8' style='border: 1px solid #1a73e8; background-color: #e8f0fe;'>"
            f"<tr><td>{report.summary}</td></tr></table>", report.conventions]
    for section in report.sections:
        body.append(f"<h2>{esc(section.title)}</h2>")
        for block in _merge_missing(section.blocks):
            body.append(_figure_html(block, images.get(block.key), scale) if isinstance(block, Figure) else block)
    return ("<!DOCTYPE html>\n<html><head><meta charset='utf-8'>"
            f"<title>{esc(report.title)}</title><style>{STYLE}</style></head><body>\n"
            + "\n".join(body) + "\n</body></html>\n")
