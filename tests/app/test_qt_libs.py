"""The system libraries Qt needs, checked before a window is tried (app/qt_libs.py)."""
from __future__ import annotations

import importlib.util
from pathlib import Path

from app.cli import main
from app.qt_libs import _CANNOT_OPEN, check_qt_libraries, package_for, platform_in_use, probe

# What Qt 6.10 printed on a machine without libxcb-icccm4 (QT_DEBUG_PLUGINS=1): its last line
# asks for xcb-cursor0, which was installed; the loader's line names the library really missing.
QT_WITHOUT_ICCCM = """\
qt.core.library: "/x/PySide6/Qt/plugins/platforms/libqxcb.so" cannot load: Cannot load library /x/PySide6/Qt/plugins/platforms/libqxcb.so: libxcb-icccm.so.4: cannot open shared object file: No such file or directory
qt.qpa.plugin: From 6.5.0, xcb-cursor0 or libxcb-cursor0 is needed to load the Qt xcb platform plugin.
qt.qpa.plugin: Could not load the Qt platform plugin "xcb" in "" even though it was found.
"""


def test_the_loader_line_names_the_library_qt_could_not_open():
    assert _CANNOT_OPEN.findall(QT_WITHOUT_ICCCM) == ["libxcb-icccm.so.4"]
    assert package_for("libxcb-icccm.so.4") == "libxcb-icccm4"
    assert package_for("libxcb-cursor.so.0") == "libxcb-cursor0"
    assert package_for("libxcb.so.1") == "libxcb1"          # the longest known prefix wins
    assert package_for("libunheard-of.so.3") is None


def test_the_platform_in_use(monkeypatch):
    monkeypatch.setenv("QT_QPA_PLATFORM", "offscreen")
    assert platform_in_use() == "offscreen"
    monkeypatch.setenv("QT_QPA_PLATFORM", "wayland;xcb")
    assert platform_in_use() == "wayland"
    monkeypatch.delenv("QT_QPA_PLATFORM")
    monkeypatch.setenv("DISPLAY", ":0")
    assert platform_in_use() == "xcb"
    monkeypatch.delenv("DISPLAY")
    monkeypatch.setenv("WAYLAND_DISPLAY", "wayland-0")
    assert platform_in_use() == "wayland"


def test_the_probe_starts_the_offscreen_plugin_and_reports_an_unknown_one():
    assert probe("offscreen") == (True, set(), "")
    started, missing, said = probe("nosuchplatform")
    assert not started and missing == set() and "nosuchplatform" in said
    check = check_qt_libraries("nosuchplatform")
    assert not check.ok and "nosuchplatform" in check.error().message


def test_no_display_is_said_before_any_window(monkeypatch, capsys):
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    monkeypatch.setenv("QT_QPA_PLATFORM", "xcb")
    check = check_qt_libraries()
    assert check.platform == "xcb" and check.no_display and not check.ok
    assert main(["gui", "--demo"]) == 1
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and "Traceback" not in err
    assert ("sudo apt-get install -y" in err) if check.missing else ("no display found" in err and "xvfb-run" in err)


def test_the_packaging_check_passes_for_the_tests_platform():
    path = Path(__file__).resolve().parents[2] / "packaging" / "check_qt_libs.py"
    spec = importlib.util.spec_from_file_location("check_qt_libs", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    assert module.main(["--platform", "offscreen"]) == 0
