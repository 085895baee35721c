"""app.jobs.check: the progress of a check adds up — "check pose k of n" comes at the fraction of
the poses done, within the check's own share of the run (the whole bar once the poses exist)."""
from __future__ import annotations

import re

import pytest

from app.jobs import check as job
from app.lab import ideal_lab_measurements, lab_options
from core.identification.file import write_calibrated_model
from core.identification.solver import identify
from core.robot.file import read_robot
from core.errors import RoboCalError
from core.robot.model import robot_path

POSES = 6


@pytest.fixture(scope="module")
def calibrated(tmp_path_factory, built_lab):
    lab = built_lab(read_robot(robot_path("educational_6r")), 0, 0.5)
    path = tmp_path_factory.mktemp("check") / "calibrated.json"
    write_calibrated_model(identify(lab.nominal_robot, ideal_lab_measurements(lab, 50, sigma_mm=0.05, seed=4)), path)
    return lab, path


def pose_fractions(marks) -> dict[int, float]:
    """{k: fraction} of the "check pose k of n" messages."""
    found = {}
    for fraction, message in marks:
        m = re.fullmatch(r"check pose (\d+) of (\d+)", message)
        if m:
            assert int(m.group(2)) == POSES
            found[int(m.group(1))] = fraction
    return found


def test_a_check_of_chosen_poses_fills_the_whole_bar_pose_by_pose(calibrated):
    lab, path = calibrated
    first = []
    cell, _, _ = job.check_project(path, lab, count=POSES, progress=lambda f, m: first.append((f, m)))
    fractions = [f for f, _ in first]
    assert fractions == sorted(fractions) and fractions[-1] == pytest.approx(1.0)
    start = 1.0 - job.check_share(None)               # the poses were chosen first: the check's share follows
    assert pose_fractions(first) == pytest.approx({k: start + job.check_share(None) * (k - 1) / POSES
                                                   for k in range(1, POSES + 1)})
    again = []
    job.check_project(path, lab, cell=cell, progress=lambda f, m: again.append((f, m)))
    assert pose_fractions(again) == pytest.approx({k: (k - 1) / POSES for k in range(1, POSES + 1)})
    assert again[-1] == (pytest.approx(1.0), "check done")


def test_choosing_the_poses_gives_most_of_the_bar_to_their_limits(calibrated):
    lab, path = calibrated
    marks = []
    job.setup(path, lab_options=lab_options(lab), count=POSES, progress=lambda f, m: marks.append((f, m)))
    limits = [f for f, m in marks if m == "limits of the check poses"]
    assert limits == [pytest.approx(job.SELECTION_SHARE)]
    assert max(f for f, m in marks if m != "ready" and m != "limits of the check poses") <= job.SELECTION_SHARE + 1e-9


def checked_tool_change(calibrated, tmp_path):
    """A check after a 1.5 mm tool change on the lab: (cell, result, diagnosis, copy of calibrated.json)."""
    lab, path = calibrated
    cell, result, diagnosis = job.check_project(path, lab, count=POSES, change="tool:1.5")
    assert diagnosis is not None and diagnosis.kind == "tool"
    out = tmp_path / "calibrated.json"
    out.write_bytes(path.read_bytes())
    return cell, result, diagnosis, out


def test_a_reidentification_whose_check_is_stopped_leaves_the_calibration_unchanged(calibrated, tmp_path):
    lab, _ = calibrated
    cell, result, diagnosis, out = checked_tool_change(calibrated, tmp_path)
    before = out.read_bytes()
    stopped = []

    def progress(fraction, message):               # Stop pressed (or a fault) during the updated robot's check
        if re.fullmatch(r"check pose 3 of \d+", message):
            stopped.append(fraction)

    with pytest.raises(RoboCalError, match=r"stopped after 3 of 6 poses.*calibrated\.json was not changed"):
        job.reidentify_on_lab(cell, result, diagnosis, lab, "tool:1.5", out, progress=progress,
                              cancelled=lambda: bool(stopped))
    assert stopped and out.read_bytes() == before
    assert not (tmp_path / "history").exists()


def test_a_completed_reidentification_is_written_with_the_previous_file_kept(calibrated, tmp_path):
    lab, _ = calibrated
    cell, result, diagnosis, out = checked_tool_change(calibrated, tmp_path)
    before = out.read_bytes()
    update = job.reidentify_on_lab(cell, result, diagnosis, lab, "tool:1.5", out)
    assert update.after.within and not update.after.cancelled
    assert update.path == out and out.read_bytes() != before
    kept = list((tmp_path / "history").iterdir())
    assert len(kept) == 1 and kept[0].read_bytes() == before
