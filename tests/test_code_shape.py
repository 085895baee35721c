"""The size of the rooms a newcomer reads: every module of app/pages at most 300 lines, and no
class of app/ or widgets/ with more than 30 methods, counting those it inherits from the
project's own classes (mixins and bases; Qt's are not counted). Read from the sources (AST).
And where a command's tests are: app/commands/X.py is tested in tests/app/commands/test_X.py."""
from __future__ import annotations

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PAGE_LINES = 300
CLASS_METHODS = 30


def project_classes() -> dict[tuple[str, str], tuple[list[str], set[str]]]:
    """(file, class name) -> (base names, own method names) over app/ and widgets/."""
    found = {}
    for package in ("app", "widgets"):
        for path in sorted((ROOT / package).rglob("*.py")):
            tree = ast.parse(path.read_text(encoding="utf-8"))
            for node in ast.walk(tree):
                if isinstance(node, ast.ClassDef):
                    bases = [b.id if isinstance(b, ast.Name) else getattr(b, "attr", "") for b in node.bases]
                    methods = {n.name for n in node.body if isinstance(n, (ast.FunctionDef, ast.AsyncFunctionDef))}
                    found[(str(path.relative_to(ROOT)), node.name)] = (bases, methods)
    return found


def methods_with_bases(key: tuple[str, str], classes: dict, seen: frozenset = frozenset()) -> set[str]:
    """The class's methods and those of its project bases (a base in the same file first, else
    the project class of that name)."""
    bases, methods = classes[key]
    total = set(methods)
    for base in bases:
        same_file = (key[0], base)
        candidates = [same_file] if same_file in classes else [k for k in classes if k[1] == base]
        for found in candidates[:1]:
            if found not in seen and found != key:
                total |= methods_with_bases(found, classes, seen | {key})
    return total


def test_every_page_module_is_at_most_300_lines():
    long = [f"{p.relative_to(ROOT)}: {n} lines" for p in sorted((ROOT / "app" / "pages").rglob("*.py"))
            if (n := len(p.read_text(encoding="utf-8").splitlines())) > PAGE_LINES]
    assert not long, long


def test_no_class_has_more_than_30_methods_with_its_project_bases():
    classes = project_classes()
    assert {"WizardPage", "MeasurementPage", "StepModel", "PageTask"} <= {name for _, name in classes}
    big = {f"{path}:{name}": len(methods_with_bases((path, name), classes)) for path, name in classes}
    assert 10 <= big["app/pages/base.py:WizardPage"] <= CLASS_METHODS
    assert not {k: v for k, v in big.items() if v > CLASS_METHODS}, {k: v for k, v in big.items() if v > CLASS_METHODS}


def test_every_module_of_app_commands_has_its_test_module():
    modules = {p.stem for p in (ROOT / "app" / "commands").glob("*.py") if p.stem != "__init__"}
    tests = {p.stem.removeprefix("test_") for p in (ROOT / "tests" / "app" / "commands").glob("test_*.py")}
    assert {"check", "identify", "options", "paths"} <= modules
    assert not modules - tests, sorted(modules - tests)
    # beside them, only the command line as a whole (app/cli.py): bad values in files, output and signals
    assert {p.name for p in (ROOT / "tests" / "app").glob("test_cli*.py")} == {"test_cli_bad_values.py",
                                                                              "test_cli_robustness.py"}
