"""`robocal gui --demo --autopilot --screenshots DIR` in a fresh process (the classroom demo):
exits 0, writes one PNG per page, removes its temporary project, and does not crash at the
interpreter's exit. The walk runs in the background while the other tests run (tests/app/gui_process.py)."""
from __future__ import annotations

import cv2
import pytest

from app.pages.steps import Step
from tests.app.gui_process import background_folder, start_walk, walk_result

pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def demo_run(tmp_path_factory):
    """The walk the session started in the background, or one walked here (without xdist)."""
    folder = background_folder()
    if folder is None:
        folder = tmp_path_factory.mktemp("demo")
        start_walk(folder).wait()
    return walk_result(folder)


def test_autopilot_runs_every_page_and_writes_screenshots(demo_run):
    assert demo_run.returncode == 0, demo_run.stdout + demo_run.stderr
    expected = [f"{s.number:02d}-{s.slug}.png" for s in Step]
    assert sorted(p.name for p in demo_run.shots.iterdir()) == expected
    for name in expected:
        image = cv2.imread(str(demo_run.shots / name))
        assert image is not None and image.shape[0] >= 600 and image.shape[1] >= 1000, name
        assert image.std() > 5, f"{name} looks uniform"
    for step in Step:
        assert f"[{step.number}/{len(Step)}] {step.info.title}:" in demo_run.stdout
    assert "every page finished" in demo_run.stdout
    assert "Traceback" not in demo_run.stderr


def test_demo_temp_project_is_removed_at_exit(demo_run):
    assert demo_run.returncode == 0, demo_run.stderr
    assert not list(demo_run.temp.glob("robocal-demo-*"))
