"""The help pages quote the chapter's equations by the chapter's own numbers.

resources/help/chapter_equations.json lists the chapter's numbered equations (number -> short
description); every number a help page quotes, in an equation's number cell or in the text
("eq. (9)", "eq. 22–25", "the chapter's (25)"), must be in it, and the key equations must sit
where the chapter has them.
"""
from __future__ import annotations

import html
import json
import re
from pathlib import Path

import pytest

from core.resources import resource_path

HELP = Path(resource_path("help"))
TABLE = json.loads((HELP / "chapter_equations.json").read_text(encoding="utf-8"))["equations"]
PAGES = sorted(HELP.glob("*.html"))

NUMBER_CELL = re.compile(r'<td[^>]*class="num"[^>]*>\s*(.*?)\s*</td>', re.S)
ROW = re.compile(r"<tr>(.*?)</tr>", re.S)
RANGE = re.compile(r"^\((\d+)\)(?:–\((\d+)\))?$")
IN_TEXT = [re.compile(r"eq\.\s*\((\d+)\)(?:\s*[–-]\s*\((\d+)\))?"),          # eq. (9), eq. (1)–(3)
           re.compile(r"eq\.\s*(\d+)(?:\s*[–-]\s*(\d+))?"),                    # eq. 22–25
           re.compile(r"chapter's\s*(?:eq\.\s*)?\((\d+)\)(?:\s*[–-]\s*\((\d+)\))?"),   # the chapter's (25)
           re.compile(r"(?:from|by|to|in|and|drops E from|with)\s\((\d+)\)(?:[–-]\((\d+)\))?")]


def _text(page: Path) -> str:
    return html.unescape(page.read_text(encoding="utf-8"))


def _plain(page: Path) -> str:
    """The page's words, tags removed and white space collapsed."""
    return " ".join(re.sub(r"<[^>]+>", "", _text(page)).split())


def _span(a: str, b: str | None) -> list[int]:
    lo, hi = int(a), int(b or a)
    assert lo <= hi, f"backwards range ({a})–({b})"
    return list(range(lo, hi + 1))


def numbered_rows(page: Path) -> dict[int, list[str]]:
    """Equation number -> the text of the rows carrying it (tags removed)."""
    rows: dict[int, list[str]] = {}
    for row in ROW.findall(_text(page)):
        for cell in NUMBER_CELL.findall(row):
            m = RANGE.match(cell)
            assert m, f"{page.name}: number cell {cell!r} is not (n) or (n)–(m)"
            plain = " ".join(re.sub(r"<[^>]+>", "", row).split())
            for n in _span(*m.groups()):
                rows.setdefault(n, []).append(plain)
    return rows


def quoted_numbers(page: Path) -> set[int]:
    text = _plain(page)
    found = set(numbered_rows(page))
    for rx in IN_TEXT:
        for m in rx.finditer(text):
            found.update(_span(*m.groups()))
    return found


def test_table_lists_the_chapter_equations_the_brief_names():
    assert "f·B/d" in TABLE["24"] and "midway" in TABLE["25"]
    assert "R" in TABLE["13"] and "T" in TABLE["13"]
    assert TABLE["8"].startswith("E") and "E" in TABLE["6"]
    assert "M·P" in TABLE["20"] and "s_i·p_i = M_i·P" in TABLE["22"]
    assert "x_d = x + Δx_r + Δx_t" in TABLE["18"]
    assert all(re.fullmatch(r"\d+", k) and v.strip() for k, v in TABLE.items())


def test_the_parser_sees_number_cells_and_quotes():
    rows = numbered_rows(HELP / "marker.html")
    assert {22, 23, 24, 25, 26, 27} <= set(rows)
    assert {1, 2, 3} <= quoted_numbers(HELP / "export.html")


@pytest.mark.parametrize("page", PAGES, ids=lambda p: p.name)
def test_every_quoted_equation_number_is_the_chapters(page):
    missing = sorted(n for n in quoted_numbers(page) if str(n) not in TABLE)
    assert not missing, f"{page.name} quotes equation numbers the chapter does not have: {missing}"


def _row(page: str, n: int) -> str:
    rows = numbered_rows(HELP / page).get(n)
    assert rows, f"{page}: no equation numbered ({n})"
    return " ".join(rows)


def test_equations_sit_where_the_chapter_has_them():
    assert "Rz(θi) · Tz(di) · Tx(ai) · Rx(αi)" in _row("setup.html", 1)
    assert "Δx = Jg · Δg" in _row("identification.html", 5)
    assert "+ E" in _row("identification.html", 6) and "E" in _row("identification.html", 8)
    assert "(ΦTΦ)−1 ΦT ΔX" in _row("identification.html", 9)
    assert "R · Xw + T" in _row("stereo.html", 13)
    assert "−y (l1r²" in _row("stereo.html", 14) and "x (l1r²" in _row("stereo.html", 17)
    assert "xd = x + Δxr + Δxt" in _row("stereo.html", 18)
    assert "p = M · P" in _row("stereo.html", 20)
    for page in ("marker.html", "measurement.html"):
        assert "si pi = Mi P" in _row(page, 22)
        assert "Z = f · b / d" in _row(page, 24)
    assert "xw = b·(u1 + u2) / (2d)" in _row("marker.html", 25)
    assert "IR(u + i − d" in _row("marker.html", 26)


def test_differences_from_the_chapter_are_explained():
    for page in ("stereo.html", "marker.html", "identification.html"):
        assert "RoboCal differs here because" in _plain(HELP / page), page
    marker = _text(HELP / "marker.html")
    assert "dist(X, ray" not in marker and "dist(X, ray" not in _text(HELP / "measurement.html")
    assert "decentring" in _text(HELP / "stereo.html") and "principal point" in _text(HELP / "stereo.html")


def test_hayati_fixes_d_i_and_d_i_plus_1_compensates():
    for page in ("setup.html", "identification.html"):
        text = _plain(HELP / page)
        assert "sin αi ≈ 0" in text, page
        assert "di+1 is ill-conditioned" not in text, page
        assert "J2.d is fixed" in text and "J3.d" in text, page
