"""The autopilot (`robocal gui --demo --autopilot`): the classroom demo walked in-process on a
project folder (the session's demo walk), and a page that fails, raises or hangs. The walk in a
fresh process: tests/app/test_autopilot_fresh_process.py; a project folder that is missing or
unreadable: tests/app/commands/test_gui.py."""
from __future__ import annotations

import pytest

from app.pages.steps import Step
from core.measurement.file import read_measurements


@pytest.mark.slow
def test_autopilot_on_a_project_folder(demo_walk):
    # `gui --demo --autopilot --screenshots DIR PROJECT` in-process: the demo is kept in PROJECT
    assert demo_walk.exit_code == 0, demo_walk.output
    assert (demo_walk.project / "project.json").is_file()
    assert (demo_walk.project / "robot.json").is_file()
    assert demo_walk.window.state.project.folder == demo_walk.project


# -- the same walk in-process, for the failure paths -------------------------------------

@pytest.fixture
def quiet_window(qtbot):
    from app import messages
    from app.main_window import MainWindow
    from app.state import WizardState
    messages.set_non_interactive(True)
    win = MainWindow(WizardState())
    qtbot.addWidget(win)
    win.show()
    yield win
    win.close()
    messages.set_non_interactive(False)


@pytest.mark.slow
def test_autopilot_in_process_finishes_with_zero(demo_walk):
    # the whole classroom run (render, calibrate, train, measure, identify, check, compensate) from a
    # fresh window, with a screenshot folder: the session's demo walk (tests/app/demo_walk.py)
    assert demo_walk.exit_code == 0, demo_walk.output
    assert len(demo_walk.saved) == 9 and demo_walk.finished_step is Step.COMPENSATION
    state = demo_walk.window.state
    assert state.project is not None and state.robot is not None


@pytest.mark.slow
def test_demo_autopilot_identifies_from_the_measured_points(demo_walk):
    """The Identification step of the classroom demo uses the points the Measurement step
    measured, not the synthetic ideal ones."""
    n = len(Step)
    assert f"[3/{n}] Marker: done" in demo_walk.output
    assert f"[5/{n}] Measurement: done (30 poses measured" in demo_walk.output
    assert f"[6/{n}] Identification: done" in demo_walk.output
    path = demo_walk.window.state.project.path("measurements")
    meas = read_measurements(path)
    assert len(meas.pose) >= 28 and meas.sigma is not None
    run = demo_walk.window.page(Step.IDENTIFICATION).run_result
    assert run.synthetic is None and run.source == path          # the measured points, not ideal ones
    assert 0.005 < run.result.after.rms_mm < 0.1 and run.result.before.rms_mm > 1.0


def test_autopilot_fails_when_a_page_fails(quiet_window, qtbot, tmp_path):
    import io
    from app.autopilot import Autopilot
    quiet_window.page(Step.STEREO).autopilot = lambda done: done(True, "calibrated")
    marker = quiet_window.page(Step.MARKER)
    marker.autopilot = lambda done: done(False, "no marker in view")
    out = io.StringIO()
    pilot = Autopilot(quiet_window, tmp_path, out=out)
    with qtbot.waitSignal(pilot.finished, timeout=60000) as blocker:      # Setup and Stereo run first
        pilot.start()
    assert blocker.args == [1]
    assert f"[3/{len(Step)}] Marker: FAILED (no marker in view)" in out.getvalue()
    assert "the Marker step failed: no marker in view" in out.getvalue()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["01-setup.png", "02-stereo.png", "03-marker.png"]


def test_autopilot_fails_when_a_page_raises_or_hangs(quiet_window, qtbot):
    import io
    from app.autopilot import Autopilot

    def raises(done):
        raise ValueError("broken page")

    quiet_window.page(Step.STEREO).autopilot = raises
    out = io.StringIO()
    pilot = Autopilot(quiet_window, out=out)
    with qtbot.waitSignal(pilot.finished, timeout=30000) as blocker:
        pilot.start()
    assert blocker.args == [1] and "ValueError: broken page" in out.getvalue()

    quiet_window.page(Step.STEREO).autopilot = lambda done: None      # never calls back
    pilot = Autopilot(quiet_window, out=out, page_timeout_s=0.2)
    with qtbot.waitSignal(pilot.finished, timeout=30000) as blocker:
        pilot.start()
    assert blocker.args == [1] and "did not finish within" in out.getvalue()
