"""Location of the files shipped in resources/ (robot presets, markers, help texts)."""
from __future__ import annotations

from pathlib import Path

import resources

RESOURCES_DIR = Path(resources.__file__).resolve().parent


def resource_path(*parts: str) -> Path:
    return RESOURCES_DIR.joinpath(*parts)
