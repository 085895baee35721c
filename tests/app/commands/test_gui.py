"""`robocal gui PROJECT` in a fresh process: a project folder that is missing is a usage error, one
that cannot be read is one line and exit 1, refused before the window's libraries are loaded.
The wizard it opens: tests/app/test_main_window.py; its autopilot: tests/app/test_autopilot.py."""
from __future__ import annotations

import subprocess
import sys

from tests.app.gui_process import ROOT, run_gui


def test_opening_a_missing_project_is_a_usage_error(tmp_path):
    proc = run_gui(str(tmp_path / "nowhere"), timeout=60)
    assert proc.returncode == 2
    assert "no such project folder" in proc.stderr and "Traceback" not in proc.stderr


def test_opening_a_bad_project_is_one_line_exit_1(tmp_path):
    (tmp_path / "project.json").write_text("{}")
    proc = run_gui(str(tmp_path), timeout=60)
    assert proc.returncode == 1
    assert proc.stderr.count("\n") == 1 and "project.json" in proc.stderr and "format" in proc.stderr


def test_a_bad_project_is_refused_before_the_window_libraries_load(tmp_path):
    (tmp_path / "project.json").write_text("{}")
    proc = subprocess.run([sys.executable, "-c", "import sys; from app.cli import main; "
                           "print(main(['gui', sys.argv[1]]), 'PySide6' in sys.modules)", str(tmp_path)],
                          cwd=ROOT, capture_output=True, text=True, timeout=60, check=False)
    assert proc.stdout.split() == ["1", "False"], proc.stdout + proc.stderr
    assert "project.json" in proc.stderr and "format" in proc.stderr
