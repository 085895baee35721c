"""Export all: every available export, one after the other (the report on a worker), then one
line saying what was written, what failed and what was skipped and why."""
from __future__ import annotations

from pathlib import Path
from typing import Callable

from app.pages.export.items import ExportItem


def export_all(items: list[ExportItem], export: Callable, *, skipped_row: Callable[[str, str], None],
               say: Callable[[str, bool], None], folder: Callable[[], Path | None],
               finished: Callable[[dict, list[str]], None] | None = None) -> None:
    """`export(key, finished=one_done)` for every item available; `skipped_row(key, missing)` for
    the others; `say(text, ok)` the summary and `finished(done, failed)` once all are done."""
    done: dict[str, list[Path]] = {}
    skipped: list[str] = []
    failed: list[str] = []
    todo = []
    for item in items:
        missing = item.missing()
        if missing:
            skipped.append(f"{item.title} ({missing})")
            skipped_row(item.key, missing)
        else:
            todo.append(item)

    def next_one() -> None:
        if not todo:
            summary()
            return
        item = todo.pop(0)

        def one_done(written: list[Path]) -> None:
            if written:
                done[item.key] = written
            else:
                failed.append(item.title)
            next_one()
        export(item.key, finished=one_done)

    def summary() -> None:
        n = sum(len(v) for v in done.values())
        text = f"✓ {n} file(s) written to {folder()}." if done else "Nothing was exported."
        if failed:
            text += " Failed: " + "; ".join(failed) + " (see the rows above)."
        if skipped:
            text += " Skipped: " + "; ".join(skipped) + "."
        say(text, bool(done) and not failed)
        if finished is not None:
            finished(done, failed)

    next_one()
