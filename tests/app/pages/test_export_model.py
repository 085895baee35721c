"""The Export step's model without Qt: where the exports go, the files written per row, and the
words of a row (its target and status)."""
from __future__ import annotations

from pathlib import Path

from app.pages.export.items import ExportItem
from app.pages.export.model import ExportModel, ExportOptions, row_status, target_text
from core.project import create_project


def item(key: str, files: tuple[str, ...], missing: str | None = None) -> ExportItem:
    return ExportItem(key, key.title(), "", files, lambda folder: [], lambda: missing)


def test_the_folder_is_the_projects_until_one_is_chosen(tmp_path):
    project = create_project(tmp_path / "p")
    model = ExportModel()
    assert model.folder(None) is None and model.folder(project) == project.folder / "export"
    heard = []
    model.on("options", heard.append)
    model.on("result", heard.append)
    model.set_options(ExportOptions(tmp_path / "out"))
    model.exported("urdf", [tmp_path / "out" / "calibrated.urdf"])
    assert model.folder(project) == tmp_path / "out" and model.result == {"urdf": [tmp_path / "out" / "calibrated.urdf"]}
    model.forget()                                                # another project
    assert model.folder(project) == project.folder / "export" and model.result == {}
    assert heard == [ExportOptions(tmp_path / "out"), {"urdf": [tmp_path / "out" / "calibrated.urdf"]},
                     ExportOptions(), {}]


def test_a_rows_words():
    stereo = item("stereo", ("stereo.yaml", "left.yaml", "right.yaml"))
    assert target_text(stereo, None, None) == "stereo.yaml, left.yaml, right.yaml"
    assert target_text(stereo, Path("/x"), None) == "→ /x/stereo.yaml (+ left.yaml, right.yaml)"
    urdf = item("urdf", ("calibrated.urdf",))
    assert target_text(urdf, Path("/x"), "result") == "→ /x/calibrated.urdf · from this session's identification"
    assert target_text(urdf, Path("/x"), "file").endswith("· from the project's calibrated.json")
    assert row_status(urdf, {}) == ("Ready.", None)
    assert row_status(urdf, {"urdf": [Path("/x/calibrated.urdf")]}) == ("✓ Exported: calibrated.urdf", True)
    later = item("urdf", ("calibrated.urdf",), "available after the Identification step")
    assert row_status(later, {"urdf": [Path("/x/calibrated.urdf")]}) == \
        ("Not available: available after the Identification step.", False)
    assert target_text(later, Path("/x"), None) == "→ /x/calibrated.urdf"         # no model named when missing
