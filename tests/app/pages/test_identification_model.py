"""The Identification step's model without Qt: the options as run_identification's keywords, the
measurements line for each state of measurements.csv, whether the run is out of date, and the
Options panel bound both ways."""
from __future__ import annotations

import inspect

import numpy as np
import pytest

from app.jobs.identification import run_identification
from app.pages.identification.model import IdentificationModel, IdentificationOptions, read_source
from core.identification.prior import PriorOptions
from core.measurement.file import Measurements, write_measurements
from core.project import Output, create_project
from core.provenance import fingerprint
from core.robot.file import read_robot
from core.robot.model import robot_path


@pytest.fixture
def robot():
    return read_robot(robot_path("educational_6r"))


def measurements(robot, n: int = 4) -> Measurements:
    Q = np.random.default_rng(2).uniform(-0.5, 0.5, (n, robot.dof))
    return Measurements(np.arange(n), ["marker"] * n, robot.q_to_file(Q), robot.target_positions(Q, "marker"))


def test_options_are_run_identifications_keywords():
    options = IdentificationOptions(huber=2.5, holdout=None, kfold=4, fixed=("J5.d", "marker.z"),
                                    prior=PriorOptions(), orientation=True, compliance="auto", payload_kg=1.5)
    keywords = options.keywords()
    accepted = inspect.signature(run_identification).parameters
    assert set(keywords) <= set(accepted)
    assert keywords["fixed"] == ["J5.d", "marker.z"] and keywords["prior"] == PriorOptions()
    assert IdentificationOptions().keywords()["holdout"] == 0.25           # the panel's default: 25 % held out


def test_the_measurements_line_follows_the_file(tmp_path, robot):
    project = create_project(tmp_path / "p")
    assert read_source(None, robot, True).html.startswith("<b>No project")
    missing = read_source(project, robot, True)
    assert "No measurements" in missing.html and missing.offer_ideal and not missing.ready
    assert not read_source(project, robot, False).offer_ideal                # ideal ones: the virtual lab only
    path = project.path(Output.MEASUREMENTS)
    path.write_text("pose,target\n1,marker\n", encoding="utf-8")
    unusable = read_source(project, robot, True)
    assert "cannot be used" in unusable.html and not unusable.ready and not unusable.offer_ideal
    write_measurements(measurements(robot), path)
    ready = read_source(project, robot, True)
    assert ready.ready and "4 poses, 4 points" in ready.html


def test_a_run_is_out_of_date_once_its_measurements_change(tmp_path, robot):
    project = create_project(tmp_path / "p")
    path = write_measurements(measurements(robot), project.path(Output.MEASUREMENTS))
    model = IdentificationModel()
    heard = []
    model.on("result", heard.append)
    model.identified("run", fingerprint({path.name: path}))                    # a run is drawn, whatever it is
    assert heard == ["run"] and model.changed_inputs(project) == [] and model.saved_path is None
    write_measurements(measurements(robot, 5), path)
    assert model.changed_inputs(project) == ["measurements.csv"]
    model.identified(None, None)
    assert heard == ["run", None] and model.changed_inputs(None) == []


def test_options_panel_both_ways(qtbot, robot):
    from app.pages.identification.options_panel import OptionsPanel
    from widgets.progress_row import ProgressRow
    panel = OptionsPanel(ProgressRow(), robot=lambda: robot, on_identify=lambda: None)
    qtbot.addWidget(panel)
    assert panel.options() == IdentificationOptions()
    chosen = IdentificationOptions(huber=2.5, holdout=None, kfold=4, fixed=("J5.d",), prior=PriorOptions(),
                                   orientation=True, compliance="on", payload_kg=1.5)
    panel.rebuild_fix_menu()
    panel.show_options(chosen)
    assert panel.options() == chosen and panel.fix_actions["J5.d"].isChecked()
    none = IdentificationOptions(holdout=None)
    panel.show_options(none)
    assert panel.options() == none and not panel.holdout_spin.isVisibleTo(panel)
