"""The Export step's model, without Qt: the folder chosen (its options; None: the project's
export/ folder) and the files written per export (its result, by row key), and the words of a
row: where its files go and what became of them.

Events: "options" (the folder changed), "result" (the files written changed)."""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from app.pages.export.items import ExportItem
from app.pages.step_model import StepModel

EXPORT_FOLDER = "export"
MODEL_ROWS = ("calibrated", "dh-csv", "urdf")        # the rows that write the calibrated model


@dataclass(frozen=True)
class ExportOptions:
    """The folder the technician chose (None: `EXPORT_FOLDER` in the project)."""

    folder: Path | None = None


class ExportModel(StepModel[ExportOptions, dict]):
    """`result`: the files written in this session, by row key ({} when none)."""

    def __init__(self):
        super().__init__(ExportOptions())
        self.result: dict[str, list[Path]] = {}

    def folder(self, project) -> Path | None:
        """Where the exports go (None: no project and no folder chosen)."""
        if self.options.folder is not None:
            return self.options.folder
        return project.folder / EXPORT_FOLDER if project is not None else None

    def exported(self, key: str, written: list[Path]) -> None:
        self.set_result({**self.result, key: written})

    def forget(self) -> None:
        """Another project: the default folder again, nothing written yet."""
        self.set_options(ExportOptions())
        self.set_result({})


def target_text(item: ExportItem, folder: Path | None, calibrated_source: str | None) -> str:
    """Where a row's files go, and which calibrated model the model rows write."""
    where = ", ".join(item.files)
    if folder is not None:
        where = f"→ {folder / item.files[0]}" + (f" (+ {', '.join(item.files[1:])})" if len(item.files) > 1 else "")
    if item.key in MODEL_ROWS and item.missing() is None:
        where += (" · from this session's identification" if calibrated_source == "result"
                  else " · from the project's calibrated.json")
    return where


def exported_text(written: list[Path]) -> str:
    return "✓ Exported: " + ", ".join(p.name for p in written)


def row_status(item: ExportItem, exported: dict[str, list[Path]]) -> tuple[str, bool | None]:
    """A row's status line and whether it is done (None: neither done nor failed)."""
    missing = item.missing()
    if missing:
        return f"Not available: {missing}.", False
    if item.key in exported:
        return exported_text(exported[item.key]), True
    return "Ready.", None
