"""The calibration report as files: a self-contained HTML (figures as base64 PNG) and a PDF
printed with QTextDocument + QPdfWriter (A4 or Letter; the sections flow one after the other;
figures never split, being single images, printed at PRINT_SCALE so that their text is 8–9 pt;
"page N of M" at the foot of every page).

    written = write_report(project, ["report.html", "report.pdf"])

Both files are written as one (core.files.atomic_write_many): a failure leaves every
previous report as it was. Needs a QApplication (offscreen is enough)."""
from __future__ import annotations

import base64
import copy
from pathlib import Path

from PySide6.QtCore import QBuffer, QByteArray, QIODevice, QMarginsF, QRectF, QSizeF, Qt, QUrl
from PySide6.QtGui import (QFont, QPageLayout, QPageSize, QPainter, QPdfWriter, QTextCursor, QTextDocument,
                           QTextFormat)

from app.report.figures import PRINT_SCALE, render_png
from core.errors import UsageError
from core.files import atomic_write_many, ensure_writable_dir
from core.report import Report, build_report, render_html
from core.task import Monitor
from widgets.png import png_bytes

PAGE_SIZES = {"a4": QPageSize.PageSizeId.A4, "letter": QPageSize.PageSizeId.Letter}
SUFFIXES = (".html", ".htm", ".pdf")
PDF_DPI = 300
MARGIN_MM = 15.0
FOOTER_MM = 8.0
HTML_SCALE = 0.85             # figure size on screen / drawn size
SHORT_TABLE_ROWS = 15         # a table this short is kept on one page with its heading
FLOAT_GAP = 0.2               # a figure leaving more than this share of a page empty above it floats


def draw_figures(report: Report, *, draw=None, progress=None, cancelled=None) -> dict:
    """Figure key -> QImage of every figure that has something to draw. `draw(figure,
    cancelled)`: how to draw one (default: here, on the GUI thread; a worker passes
    `GuiDrawer.draw`)."""
    monitor = Monitor(progress, cancelled)
    todo = [f for f in report.figures() if not f.unavailable and f.panels]
    images = {}
    for i, fig in enumerate(todo):
        monitor.step(i / max(len(todo), 1), f"drawing figure {i + 1} of {len(todo)}: {fig.title}")
        images[fig.key] = draw(fig, cancelled) if draw is not None else render_png(fig)
    monitor.step(1.0, "figures drawn")
    return images


def html_document(report: Report, images: dict) -> str:
    """Self-contained HTML: each image a data URI."""
    srcs = {k: "data:image/png;base64," + base64.b64encode(png_bytes(img)).decode("ascii")
            for k, img in images.items()}
    return render_html(report, srcs, scale=HTML_SCALE)


def pdf_document(report: Report, images: dict, page_size: str = "a4") -> bytes:
    """The report printed to PDF, as bytes."""
    data = QByteArray()
    buffer = QBuffer(data)
    buffer.open(QIODevice.OpenModeFlag.WriteOnly)
    writer = QPdfWriter(buffer)
    writer.setResolution(PDF_DPI)
    writer.setTitle(report.title)
    writer.setCreator("RoboCal")
    writer.setPageLayout(QPageLayout(QPageSize(PAGE_SIZES[page_size]), QPageLayout.Orientation.Portrait,
                                     QMarginsF(MARGIN_MM, MARGIN_MM, MARGIN_MM, MARGIN_MM),
                                     QPageLayout.Unit.Millimeter))
    rect = writer.pageLayout().paintRectPixels(PDF_DPI)
    footer = FOOTER_MM / 25.4 * PDF_DPI
    page_h = rect.height() - footer

    doc = _laid_out(report, images, writer, rect.width(), page_h)
    pages = doc.pageCount()
    painter = QPainter(writer)
    try:
        note = QFont(doc.defaultFont())
        note.setPointSizeF(8)
        for i in range(pages):
            if i:
                writer.newPage()
            painter.save()
            painter.translate(0, -i * page_h)
            doc.drawContents(painter, QRectF(0, i * page_h, rect.width(), page_h))
            painter.restore()
            painter.setFont(note)
            painter.setPen(Qt.GlobalColor.darkGray)
            foot = QRectF(0, page_h, rect.width(), footer)
            painter.drawText(foot, Qt.AlignmentFlag.AlignBottom | Qt.AlignmentFlag.AlignLeft, report.title)
            painter.drawText(foot, Qt.AlignmentFlag.AlignBottom | Qt.AlignmentFlag.AlignRight,
                             f"page {i + 1} of {pages}")
    finally:
        painter.end()
        buffer.close()
    return bytes(data)


def _document(report: Report, images: dict, device, width: float, page_h: float) -> QTextDocument:
    doc = QTextDocument()
    doc.documentLayout().setPaintDevice(device)      # pt sizes in the writer's pixels
    doc.setDocumentMargin(0)
    font = QFont("DejaVu Sans")
    font.setPointSizeF(9.5)
    doc.setDefaultFont(font)
    doc.setPageSize(QSizeF(width, page_h))
    for key, img in images.items():
        doc.addResource(QTextDocument.ResourceType.ImageResource, QUrl(f"figure:{key}"), img)
    # QTextDocument sizes images in 96 dpi pixels: a figure's drawn px times PRINT_SCALE on paper
    doc.setHtml(render_html(report, {k: f"figure:{k}" for k in images}, scale=PRINT_SCALE))
    return doc


def _figure_key(block) -> str | None:
    """The key of the report figure in a text block, or None."""
    it = block.begin()
    while not it.atEnd():
        fmt = it.fragment().charFormat()
        if fmt.isImageFormat() and fmt.toImageFormat().name().startswith("figure:"):
            return fmt.toImageFormat().name().removeprefix("figure:")
        it += 1
    return None


def _gap_before_figure(doc: QTextDocument, page_h: float, skip: set) -> str | None:
    """The key of the first figure (not in `skip`) pushed to the next page with more than
    FLOAT_GAP of a page left empty above it, or None."""
    layout = doc.documentLayout()
    block = doc.begin()
    while block.isValid():
        key = _figure_key(block)
        if key is not None and key not in skip and block.previous().isValid():
            top = layout.blockBoundingRect(block).top() + block.layout().lineAt(0).y()
            above = layout.blockBoundingRect(block.previous()).bottom()
            if int(top // page_h) > int(above // page_h) and top - above > FLOAT_GAP * page_h:
                return key
        block = block.next()
    return None


def _laid_out(report: Report, images: dict, device, width: float, page_h: float) -> QTextDocument:
    """The report laid out on pages of `width` × `page_h`; a figure that would leave a large gap
    at the foot of a page floats: the text after it in its section comes first (as LaTeX does),
    and the figure follows that text."""
    report = copy.copy(report)
    report.sections = [copy.copy(s) for s in report.sections]
    for s in report.sections:
        s.blocks = list(s.blocks)
    tried: set[str] = set()
    doc = _document(report, images, device, width, page_h)
    while (key := _gap_before_figure(doc, page_h, tried)) is not None:
        tried.add(key)                   # each figure floats once at most
        section = next(s for s in report.sections if key in [getattr(b, "key", None) for b in s.blocks])
        i = [getattr(b, "key", None) for b in section.blocks].index(key)
        j = i + 1
        while j < len(section.blocks) and isinstance(section.blocks[j], str):
            j += 1
        if j > i + 1:                    # the text up to the next figure goes first
            section.blocks[i:j] = section.blocks[i + 1:j] + [section.blocks[i]]
            doc = _document(report, images, device, width, page_h)
    _keep_headings_with_what_follows(doc, page_h)
    return doc


def _keep_headings_with_what_follows(doc: QTextDocument, page_h: float) -> None:
    """A heading at the foot of a page, parted from the text or the short table after it, starts
    the next page instead."""
    layout = doc.documentLayout()
    block = doc.begin()
    while block.isValid():
        following = block.next()
        if block.blockFormat().headingLevel() > 0 and following.isValid():
            rect = layout.blockBoundingRect(block)
            page = int(rect.top() // page_h)
            table = QTextCursor(following).currentTable()
            if table is not None and table.rows() <= SHORT_TABLE_ROWS:
                end = layout.frameBoundingRect(table).bottom()
            elif table is not None:
                end = rect.bottom() + 3 * rect.height()             # a long table: its first rows
            else:
                end = layout.blockBoundingRect(following).top() + following.layout().lineAt(0).height()
                after = following.next()
                if following.layout().lineCount() <= 2 and after.isValid() and _figure_key(after):
                    end = layout.blockBoundingRect(after).top() + after.layout().lineAt(0).y() + 1  # its figure
            if int(end // page_h) > page and end - rect.top() < page_h:
                fmt = block.blockFormat()
                fmt.setPageBreakPolicy(QTextFormat.PageBreakFlag.PageBreak_AlwaysBefore)
                QTextCursor(block).setBlockFormat(fmt)
        block = block.next()


def check_report_path(path: str | Path, option: str = "--out") -> Path:
    path = Path(path)
    if path.suffix.lower() not in SUFFIXES:
        raise UsageError(f"{option} must end in .html or .pdf, got {str(path)!r}")
    return path


def write_report(project, outputs, *, robot=None, identification=None, accuracy=None, page_size: str = "a4",
                 figures_dir: str | Path | None = None, draw=None, progress=None, cancelled=None,
                 author: str | None = None, course: str | None = None, serial: str | None = None) -> list[Path]:
    """Build the report of `project` and write it to each path of `outputs` (.html or .pdf) as one
    atomic write; with `figures_dir`, also every figure as PNG there. Runs on a worker when
    `draw` is a `GuiDrawer.draw` (app/report/gui_drawer.py); without it, on the GUI thread.
    Output folders are checked before any work: one that cannot be written to is named at once.
    `author`, `course`, `serial` (the robot's serial number) go into the title block."""
    monitor = Monitor(progress, cancelled)
    outputs = [check_report_path(p) for p in outputs]
    for folder in {p.parent for p in outputs} | ({Path(figures_dir)} if figures_dir is not None else set()):
        ensure_writable_dir(folder)
    monitor.step(0.0, "reading the project")
    report = build_report(project, robot=robot, identification=identification, accuracy=accuracy, author=author,
                          course=course, serial=serial)
    images = draw_figures(report, draw=draw, progress=monitor.sub(0.05, 0.7), cancelled=cancelled)
    files: dict = {}
    for i, path in enumerate(outputs):
        monitor.step(0.7 + 0.25 * i / len(outputs), f"writing {path.name}")
        files[path] = (pdf_document(report, images, page_size) if path.suffix.lower() == ".pdf"
                       else html_document(report, images))
    if figures_dir is not None:
        folder = Path(figures_dir)
        for fig in report.figures():
            if fig.key in images:
                files[folder / f"{fig.key}.png"] = png_bytes(images[fig.key])
    monitor.step(0.95, "saving")
    written = atomic_write_many(files)
    monitor.step(1.0, "report written")
    return written
