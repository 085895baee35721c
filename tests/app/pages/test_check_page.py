"""The Check page on the virtual lab: a check without change stays within limits and is logged,
a simulated tool change is found and named, re-identification brings the next check back and
writes a new calibrated.json (the previous kept in history/) that Export then writes, a failed
re-identification leaves no trace, a missing calibration is said plainly, the schedule, and a
screenshot after a detected change."""
from __future__ import annotations

import pytest

from app.lab import ideal_lab_measurements
from app.pages.check.page import MISSING, CheckPage
from app.pages.export.page import ExportPage
from app.state import WizardState
from app.worker import TaskRunner
from core.identification.file import write_calibrated_model
from core.identification.solver import identify
from core.monitoring.log import read_check_log
from core.robot.file import read_robot, write_robot

TIMEOUT = 120_000


def open_page(qtbot, state: WizardState, tasks: TaskRunner) -> CheckPage:
    """The Check page of `state`, shown and entered."""
    p = CheckPage(state, tasks)
    qtbot.addWidget(p)
    p.resize(1100, 760)
    p.show()
    p.on_enter()
    return p


@pytest.fixture
def page(qtbot, tmp_path):
    state, tasks = WizardState(), TaskRunner()
    state.new_project(tmp_path / "project")
    state.choose_preset("educational_6r")
    yield open_page(qtbot, state, tasks)
    tasks.shutdown()
    state.close()


def calibrate(page):
    """This session's identification, saved as the project's calibrated.json."""
    lab = page.state.labs.ready_now()
    result = identify(lab.nominal_robot, ideal_lab_measurements(lab, 50, sigma_mm=0.05, seed=4))
    write_calibrated_model(result, page.calibrated_path())
    page.refresh()
    return result


def run_check(page, qtbot) -> None:
    assert page.run_check()
    qtbot.waitUntil(lambda: not page.task.busy, timeout=TIMEOUT)
    assert page.result is not None, page.status.text()


def test_missing_calibration_is_said_plainly(page):
    assert not page.run_check()
    assert page.status.text() == MISSING and "Run the Identification step first" in MISSING
    assert not page.controls.run_button.isEnabled() and not page.results.reidentify_button.isEnabled()


def test_no_change_within_limits_and_logged(page, qtbot):
    calibrate(page)
    assert page.controls.run_button.isEnabled()
    run_check(page, qtbot)
    assert page.result.within and page.diagnosis is None, page.result.verdict()
    assert page.controls.poses_list.count() == 8
    log = read_check_log(page.log_path())
    assert len(log.checks) == 1 and len(log.checks[0].points) == 8 and log.checks[0].within
    assert page.results.overall_chart.beyond_count == 0 and len(page.results.pose_charts) == 8
    assert page.is_complete()


def test_a_payload_other_than_the_calibrations_is_said_after_the_check(page, qtbot):
    calibrate(page)
    model = read_robot(page.calibrated_path())
    model.calibration["payload_kg"] = 1.0
    write_robot(model, page.calibrated_path())
    page.refresh()
    assert not page.controls.payload_spin.isEnabled() and page.controls.payload_kg() is None
    run_check(page, qtbot)
    assert "Payload" not in page.status.text()                      # not said: nothing to compare
    page.controls.payload_check.setChecked(True)
    page.controls.payload_spin.setValue(3.0)
    assert page.controls.payload_kg() == 3.0
    run_check(page, qtbot)
    assert "Payload: 3 kg declared, 1 kg during calibration: the arm bends more under a heavier tool." \
        in page.status.text()
    page.controls.payload_spin.setValue(1.0)
    run_check(page, qtbot)
    assert "Payload" not in page.status.text()                      # the same payload: nothing to say


def test_tool_change_found_reidentified_and_back_within(page, qtbot, tmp_path):
    page.state.set_identification(calibrate(page))
    export = ExportPage(page.state, page.task.runner)
    qtbot.addWidget(export)
    assert export.calibrated_source() == "result"
    before = page.calibrated_path().read_text()
    page.controls.choose_change("tool", 1.5)
    run_check(page, qtbot)
    assert not page.result.within
    assert page.diagnosis.kind == "tool" and "on the tool" in page.results.diagnosis_label.text()
    assert page.results.reidentify_button.isEnabled()
    assert page.results.overall_chart.beyond_count == 1
    shot = tmp_path / "check-tool-change.png"
    page.grab().save(str(shot))
    assert shot.stat().st_size > 10_000

    assert page.reidentify()
    qtbot.waitUntil(lambda: not page.task.busy, timeout=TIMEOUT)
    assert page.reidentification is not None, page.status.text()
    assert page.result.within and "Re-identified marker.x" in page.status.text()
    after = read_robot(page.calibrated_path())
    assert after.calibration["history"][-1]["changed"] == ["marker.x", "marker.y", "marker.z"]
    kept = list((page.calibrated_path().parent / "history").glob("calibrated-*.json"))
    assert len(kept) == 1 and kept[0].read_text() == before
    assert after.calibration["history"][-1]["updated"] == kept[0].name
    assert page.state.identification is None and export.calibrated_source() == "file"   # the newer file wins
    (written,) = export.export("calibrated")
    assert written.read_bytes() == page.calibrated_path().read_bytes()
    assert read_robot(written).calibration["history"][-1]["changed"] == ["marker.x", "marker.y", "marker.z"]

    run_check(page, qtbot)                                # the change is still there: the new model fits it
    assert page.result.within, page.result.verdict()
    log = read_check_log(page.log_path())
    assert [c.within for c in log.checks] == [False, True, True]
    assert page.results.overall_chart.beyond_count == 1 and len(page.results.overall_chart.x) == 3


def test_failed_reidentification_leaves_no_trace(page, qtbot):
    calibrate(page)
    before = page.calibrated_path().read_bytes()
    page.controls.choose_change("tool", 1.5)
    run_check(page, qtbot)
    assert page.diagnosis.kind == "tool"
    page.controls.choose_change("link", 1.0, joint=3)    # the data of the re-identification: a bent link
    assert page.reidentify()
    qtbot.waitUntil(lambda: not page.task.busy, timeout=TIMEOUT)
    assert page.reidentification is None and "full calibration" in page.status.text()
    assert page.calibrated_path().read_bytes() == before
    history = page.calibrated_path().parent / "history"
    assert not history.exists() or not any(history.iterdir())


def test_log_survives_a_new_page(page, qtbot):
    calibrate(page)
    run_check(page, qtbot)
    again = CheckPage(page.state, page.task.runner)
    qtbot.addWidget(again)
    again.on_enter()
    assert len(again.results.overall_chart.x) == 1 and again.is_complete()


def test_schedule_off_by_default_and_follows_the_minutes(page):
    assert not page.schedule_timer.isActive()
    page.controls.minutes_spin.setValue(3)
    page.controls.schedule_check.setChecked(True)
    assert page.schedule_timer.isActive() and page.schedule_timer.interval() == 3 * 60_000
    page.controls.schedule_check.setChecked(False)
    assert not page.schedule_timer.isActive()


def test_the_change_as_the_lab_reads_it(page):
    page.controls.choose_change("joint", -0.4, joint=3)
    assert page.controls.change_spec() == "joint3:-0.4"
    page.controls.choose_change("base", -2.0)
    assert page.controls.change_spec() == "base:2"
    page.controls.choose_change("", 1.0)
    assert page.controls.change_spec() is None


def test_one_tool_hides_the_tool_selector(page):
    assert page.controls.tool_box.isHidden() and page.controls.tool() is None
    labels = [page.controls.change_combo.itemText(i) for i in range(page.controls.change_combo.count())]
    assert "another tool mounted" not in labels


@pytest.fixture
def two_tool_page(qtbot, tmp_path):
    from tests.core.tools.two_tools import two_tool_robot
    state, tasks = WizardState(), TaskRunner()
    state.new_project(tmp_path / "project")
    state.set_robot(two_tool_robot(), "two tools")
    yield open_page(qtbot, state, tasks)
    tasks.shutdown()
    state.close()


def test_two_tools_identify_the_second_then_check_with_each(two_tool_page, qtbot):
    page = two_tool_page
    calibrate(page)
    assert not page.controls.tool_box.isHidden()
    assert [page.controls.tool_combo.itemText(i) for i in range(2)] == ["gripper", "long_gripper"]
    page.controls.choose_tool("long_gripper")
    assert page.run_check()
    qtbot.waitUntil(lambda: not page.task.busy, timeout=TIMEOUT)
    assert page.result is None and "has not been identified" in page.status.text()

    assert page.identify_tool()
    qtbot.waitUntil(lambda: not page.task.busy, timeout=TIMEOUT)
    assert page.tool_update is not None, page.status.text()
    assert "Tool 'long_gripper' identified from 5 poses" in page.status.text()
    assert read_robot(page.calibrated_path()).calibration["tools"] == ["gripper", "long_gripper"]
    assert len(list((page.calibrated_path().parent / "history").glob("calibrated-*.json"))) == 1

    run_check(page, qtbot)
    assert page.result.within and page.result.tool == "long_gripper", page.result.verdict()
    page.controls.choose_change("mount", 0.0, tool="gripper")
    assert page.controls.change_spec() == "mount:gripper"
    run_check(page, qtbot)
    assert not page.result.within and page.diagnosis.kind == "tool"
    assert "the tool 'long_gripper'" in page.results.diagnosis_label.text()
    assert [c.tool for c in read_check_log(page.log_path()).checks] == ["long_gripper", "long_gripper"]
