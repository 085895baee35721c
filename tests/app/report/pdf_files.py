"""Reading back a PDF the report wrote: its text and its pages (poppler-utils' pdftotext, pdfinfo)."""
from __future__ import annotations

import re
import shutil
import subprocess

HAVE_POPPLER = shutil.which("pdftotext") is not None and shutil.which("pdfinfo") is not None


def pdf_text(path) -> str:
    text = subprocess.run(["pdftotext", "-layout", str(path), "-"], capture_output=True, text=True,
                          check=True).stdout
    return text.replace("\ufb01", "fi").replace("\ufb02", "fl")        # the font's ligatures


def pdf_pages(path) -> tuple[int, str]:
    info = subprocess.run(["pdfinfo", str(path)], capture_output=True, text=True, check=True).stdout
    return int(re.search(r"Pages:\s+(\d+)", info).group(1)), re.search(r"Page size:\s+(.*)", info).group(1)
