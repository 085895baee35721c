"""Measurement files marked synthetic: an ordinary measurements.csv with one extra comment
line (``# synthetic: …``) saying how it was made, so every screen and report can label it.

    write_synthetic_measurements(meas, project.path(Output.MEASUREMENTS), note="ideal virtual-lab …")
    is_synthetic(project.path(Output.MEASUREMENTS))   # True
"""
from __future__ import annotations

from pathlib import Path

from core.files import atomic_write_text
from core.measurement.file import Measurements, format_measurements

SYNTHETIC_TAG = "# synthetic:"

def write_synthetic_measurements(meas: Measurements, path: str | Path, note: str) -> Path:
    """Write `meas` as measurements.csv (atomically) with the comment line ``# synthetic: note``."""
    lines = format_measurements(meas).splitlines(keepends=True)
    return atomic_write_text(path, lines[0] + f"{SYNTHETIC_TAG} {note}\n" + "".join(lines[1:]))


def synthetic_description(path: str | Path) -> str | None:
    """What the synthetic note of a measurements file says (the text after '# synthetic:'),
    or None for real measurements or an unreadable file. Reads only the comment lines at the top."""
    try:
        with open(path, encoding="utf-8-sig") as handle:
            for _ in range(20):
                line = handle.readline()
                if not line:
                    break
                line = line.strip()
                if line.startswith(SYNTHETIC_TAG):
                    return line[len(SYNTHETIC_TAG):].strip() or "synthetic"
                if line and not line.startswith("#"):
                    break
    except (OSError, UnicodeDecodeError):
        return None
    return None


def is_synthetic(path: str | Path) -> bool:
    return synthetic_description(path) is not None
