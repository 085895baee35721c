"""The dependency direction app → widgets → core, checked three ways:
import-linter's contracts (pyproject.toml), an AST scan of the sources, and a fresh
interpreter importing every core module without loading Qt."""
from __future__ import annotations

import ast
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
QT_MODULES = {"PySide6", "pyqtgraph", "shiboken6", "PyQt5", "PyQt6", "PySide2", "qtpy", "superqt"}


def imported_top_modules(path: Path) -> set[tuple[str, int]]:
    """(top-level module, line) of every absolute import in a file."""
    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    found = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            found |= {(alias.name.split(".")[0], node.lineno) for alias in node.names}
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            found.add((node.module.split(".")[0], node.lineno))
        elif (isinstance(node, ast.Call) and getattr(node.func, "attr", getattr(node.func, "id", ""))
              in ("import_module", "__import__") and node.args
              and isinstance(node.args[0], ast.Constant) and isinstance(node.args[0].value, str)):
            found.add((node.args[0].value.split(".")[0], node.lineno))
    return found


def sources(package: str) -> list[Path]:
    return sorted((ROOT / package).rglob("*.py"))


def violations(package: str, forbidden: set[str]) -> list[str]:
    return [f"{path.relative_to(ROOT)}:{line} imports {module}"
            for path in sources(package) for module, line in sorted(imported_top_modules(path))
            if module in forbidden]


def test_core_never_imports_qt_or_the_upper_layers():
    assert sources("core")
    assert violations("core", QT_MODULES | {"widgets", "app"}) == []


def test_widgets_never_import_app():
    assert violations("widgets", {"app"}) == []


def test_jobs_never_import_qt_or_widgets():
    """app/jobs run on worker threads and are tested without a window."""
    assert sources("app/jobs")
    assert violations("app/jobs", QT_MODULES | {"widgets"}) == []


def test_the_ast_check_sees_imports(tmp_path):
    f = tmp_path / "m.py"
    f.write_text("import os\nfrom PySide6.QtCore import Qt\nimport importlib\n"
                 "importlib.import_module('pyqtgraph.opengl')\nfrom . import sibling\n")
    assert {m for m, _ in imported_top_modules(f)} == {"os", "PySide6", "importlib", "pyqtgraph"}


def lint_imports_command() -> list[str]:
    exe = Path(sys.executable).with_name("lint-imports")
    if exe.exists():
        return [str(exe)]
    found = shutil.which("lint-imports")
    if found:
        return [found]
    pytest.skip("import-linter is not installed (pip install -e '.[test]')")


def test_import_linter_contracts_are_kept():
    proc = subprocess.run([*lint_imports_command(), "--no-cache"], cwd=ROOT, capture_output=True,
                          text=True, timeout=300)
    out = proc.stdout + proc.stderr
    assert proc.returncode == 0, out
    assert "broken" in out and " 0 broken" in out
    assert "Layers: app -> widgets -> core KEPT" in out
    assert "core never imports Qt or pyqtgraph KEPT" in out
    assert "Only the virtual lab's own package, and app.lab, import the virtual lab KEPT" in out
    assert "Inside core: a step imports only the steps below it, and the shared pieces KEPT" in out
    assert "app.jobs imports no Qt and no widgets KEPT" in out


def test_importing_all_of_core_does_not_load_qt():
    code = """
import importlib, pkgutil, sys, traceback
import core
failed = []
names = []
for info in pkgutil.walk_packages(core.__path__, "core."):
    names.append(info.name)
    try:
        importlib.import_module(info.name)
    except Exception as exc:
        failed.append(f"{info.name}: {type(exc).__name__}: {exc}")
qt = sorted(m for m in sys.modules if m.split(".")[0] in {QT})
print("MODULES", len(names))
print("FAILED", failed)
print("QT", qt)
""".replace("{QT}", repr(QT_MODULES))
    env = dict(os.environ)
    env.pop("PYTHONSTARTUP", None)
    proc = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True,
                          timeout=300, env=env)
    assert proc.returncode == 0, proc.stderr
    lines = dict(line.split(" ", 1) for line in proc.stdout.splitlines() if " " in line)
    assert int(lines["MODULES"]) >= 10
    assert lines["QT"] == "[]", f"importing core loaded Qt: {lines['QT']}"
    assert lines["FAILED"] == "[]", f"core modules that fail to import: {lines['FAILED']}"


def test_only_the_lab_service_imports_the_virtual_lab():
    """Every module outside core/virtual_lab (and app/lab.py, the app's lab service) is checked,
    including the ones added after the import-linter contract's list was written."""
    def imports_lab(path: Path) -> list[int]:
        tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
        lines = []
        for node in ast.walk(tree):
            names = ([a.name for a in node.names] if isinstance(node, ast.Import) else
                     [node.module or ""] if isinstance(node, ast.ImportFrom) else [])
            if any(n == "core.virtual_lab" or n.startswith("core.virtual_lab.") for n in names):
                lines.append(node.lineno)
        return lines

    allowed = {ROOT / "app" / "lab.py"}
    found = [f"{p.relative_to(ROOT)}:{line}" for package in ("core", "widgets", "app") for p in sources(package)
             if p not in allowed and (ROOT / "core" / "virtual_lab") not in p.parents for line in imports_lab(p)]
    assert found == []
