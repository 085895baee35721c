"""The report drawn with Qt: figures as images, the self-contained HTML, the PDF (pages,
page numbers, page sizes), a read-only project or output folder, and a failing writer leaving the
previous report. `robocal report`'s own tests: tests/app/commands/test_report.py."""
from __future__ import annotations

import contextlib
import errno
import os
import re
import shutil
import subprocess

import pytest
from PySide6.QtGui import QImage

from app.cli import main
from app.report.render import draw_figures, pdf_document, write_report
from core.errors import RoboCalError
from core.project import open_project
from core.report import build_report
from tests.app.report.pdf_files import HAVE_POPPLER, pdf_pages, pdf_text
from tests.core.report.sample_project import make_project

@pytest.fixture(scope="module")
def project(tmp_path_factory):
    return make_project(tmp_path_factory.mktemp("render") / "project")[0]


@pytest.fixture(scope="module")
def drawn(qapp, project):
    """(report, draw_figures(report)) of the sample project, drawn once: the images are only read
    (drawing is deterministic; `robocal report` in the tests below still draws its own)."""
    report = build_report(open_project(project.folder))
    return report, draw_figures(report)


@pytest.fixture
def draw(drawn):
    """write_report's `draw`: a figure of the sample project as drawn once (`drawn`), for the
    tests of what is written around the figures."""
    images = drawn[1]
    return lambda fig, cancelled=None: images[fig.key]


def test_every_drawable_figure_is_an_image_with_ink(drawn):
    report, images = drawn
    drawable = [f.key for f in report.figures() if not f.unavailable]
    assert sorted(images) == sorted(drawable) and len(images) >= 12
    sizes = {f.key: f.size for f in report.figures()}
    for key, img in images.items():
        # print resolution: 2.5 image px per figure px (a 900 px figure, 24 cm wide, at about 240 dpi)
        assert isinstance(img, QImage) and img.width() == int(sizes[key][0] * 2.5) >= 1400, key
        # not blank: a white background with something drawn on it
        small = img.scaled(60, 30)
        colours = {small.pixel(x, y) for x in range(60) for y in range(30)}
        assert len(colours) > 5, key


def test_html_is_self_contained(qapp, project, tmp_path, draw):
    out = write_report(open_project(project.folder), [tmp_path / "r.html"], draw=draw)[0]
    text = out.read_text()
    assert text.count("<img src='data:image/png;base64,") == 12
    assert "src='figure:" not in text and "file:" not in text


@pytest.mark.skipif(not HAVE_POPPLER, reason="poppler-utils (pdftotext, pdfinfo) not installed")
@pytest.mark.parametrize("size, points", [("a4", "595 x 842 pts"), ("letter", "612 x 792 pts")])
def test_pdf_has_pages_numbers_and_sections(drawn, tmp_path, size, points):
    out = tmp_path / "r.pdf"
    out.write_bytes(pdf_document(*drawn, size))
    pages, page_size = pdf_pages(out)
    assert pages > 5 and page_size.startswith(points)
    text = pdf_text(out)
    for i in range(1, pages + 1):
        assert f"page {i} of {pages}" in text
    for title in ("Stereo calibration", "Pose sequence", "Measurements", "Identification", "Reprojection error per pair",
                  "Error per pose, before and after"):
        assert title in text, title
    # the sections flow: a section starts where the previous one ends, not on a page of its own
    tops = [p.strip().splitlines()[0] for p in text.split("\f") if p.strip()]
    assert sum(title in tops for title in ("Stereo calibration", "Marker", "Pose sequence", "Measurements",
                                           "Identification")) <= 2, tops


@pytest.mark.skipif(not HAVE_POPPLER, reason="poppler-utils (pdftotext, pdfinfo) not installed")
def test_pdf_pages_are_filled_and_few(qapp, project, tmp_path, draw):
    """The sample project (stereo, poses, measurements, identification; no marker, check or
    compensation) on a few full pages: every page but the last holds text down to its lower half."""
    out = write_report(open_project(project.folder), [tmp_path / "r.pdf"], author="Ana Student",
                       course="Robotics 2", serial="RCS6-0421", draw=draw)[0]
    pages, _ = pdf_pages(out)
    assert 4 <= pages <= 8, pages
    bbox = subprocess.run(["pdftotext", "-bbox", str(out), "-"], capture_output=True, text=True, check=True).stdout
    for i, page in enumerate(bbox.split("<page ")[1:pages], start=1):       # all but the last
        height = float(re.search(r'height="([\d.]+)"', page).group(1))
        words = [float(y) for y in re.findall(r'yMax="([\d.]+)"', page)]
        # the lowest word above the footer line ("page N of M", 15 mm from the foot) shows how far
        # down the page is filled (a figure is always followed by its caption)
        body = max([y for y in words if y < height - 50], default=0.0)
        assert body > 0.5 * height, (i, body, height)
    text = pdf_text(out)
    assert "Ana Student" in text and "RCS6-0421" in text and "not available" not in text


def test_a_full_disk_keeps_the_previous_report(qapp, project, tmp_path, monkeypatch, draw):
    html, pdf = tmp_path / "r.html", tmp_path / "r.pdf"
    html.write_text("previous html")
    pdf.write_bytes(b"previous pdf")
    real_fsync, calls = os.fsync, []

    def fsync(fd):               # the second file's data does not fit on the disk
        calls.append(fd)
        if len(calls) == 2:
            raise OSError(errno.ENOSPC, "No space left on device")
        return real_fsync(fd)

    monkeypatch.setattr(os, "fsync", fsync)
    with pytest.raises(RoboCalError) as caught:
        write_report(open_project(project.folder), [html, pdf], draw=draw)
    assert "No space left on device" in caught.value.message and "no output was changed" in caught.value.message
    assert html.read_text() == "previous html" and pdf.read_bytes() == b"previous pdf"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["r.html", "r.pdf"]


@contextlib.contextmanager
def read_only(folder):
    """`folder` made read-only: chmod for a user, the immutable attribute for root (whom
    permission bits do not stop)."""
    if os.geteuid() == 0:
        if shutil.which("chattr") is None or subprocess.run(["chattr", "+i", str(folder)],
                                                            capture_output=True).returncode:
            pytest.skip("running as root without chattr +i: a folder cannot be made read-only")
        try:
            yield folder
        finally:
            subprocess.run(["chattr", "-i", str(folder)], check=True)
    else:
        mode = folder.stat().st_mode
        folder.chmod(0o555)
        try:
            yield folder
        finally:
            folder.chmod(mode)


def test_a_read_only_output_folder_is_named_before_any_work(qapp, project, tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    drawn = []
    with read_only(out):
        with pytest.raises(RoboCalError) as caught:
            write_report(open_project(project.folder), [out / "r.html", out / "r.pdf"],
                         draw=lambda fig, cancelled=None: drawn.append(fig))
    assert f"{out}: the folder is not writable" in caught.value.message
    assert drawn == [] and list(out.iterdir()) == []


def test_a_read_only_project_is_reported_and_left_as_it_was(qapp, project, tmp_path, capsys):
    folder = shutil.copytree(project.folder, tmp_path / "project")
    before = sorted(p.relative_to(folder) for p in folder.rglob("*"))
    with read_only(folder):
        code = main(["report", str(folder), "--out", str(tmp_path / "r.pdf"), "--no-truth"])
        assert code == 0, capsys.readouterr().err
        code = main(["report", str(folder), "--out", str(folder / "export" / "r.pdf"), "--no-truth"])
        err = capsys.readouterr().err
    assert code != 0 and f"{folder} is not writable" in err and "Traceback" not in err
    assert len(err.strip().splitlines()) <= 2                   # one message (and its hint)
    assert sorted(p.relative_to(folder) for p in folder.rglob("*")) == before
    assert (tmp_path / "r.pdf").read_bytes().startswith(b"%PDF")
