"""The report's inputs are loaded once and each section is drawn from them alone: a section
gives the same result whatever was drawn before it, and a file that cannot be read is named
by its own section only."""
import shutil

import pytest

from core.project import open_project
from core.report.build import build_report
from core.report.identification import identification_section
from core.report.inputs import load_report_inputs
from core.report.measurement import measurement_section
from core.report.stereo import stereo_section
from core.stereo.file import read_stereo_yaml
from tests.core.report.sample_project import make_project


@pytest.fixture(scope="module")
def sample(tmp_path_factory):
    project, _ = make_project(tmp_path_factory.mktemp("inputs") / "project")
    return open_project(project.folder)


def panels(section):
    return [(f.key, f.unavailable, repr(f.panels)) for f in section.figures()]


def test_each_file_is_read_into_the_inputs(sample):
    inputs = load_report_inputs(sample, problems=(problems := []))
    assert problems == [] and inputs.robot is not None
    assert inputs.stereo.get().rms_stereo == read_stereo_yaml(sample.path("stereo")).rms_stereo
    assert inputs.measurements.get().n_poses > 0
    assert inputs.calibration.get().source == "calibrated.json" and "statistics" in inputs.calibration.get().section


def test_a_section_does_not_depend_on_the_sections_drawn_before_it(sample):
    inputs = load_report_inputs(sample, problems=[])
    alone = measurement_section(inputs, []), identification_section(inputs, [])
    stereo_section(inputs, [])
    after = measurement_section(inputs, []), identification_section(inputs, [])
    for a, b in zip(alone, after):
        assert a.done and panels(a) == panels(b)
    views = next(f for f in alone[0].figures() if f.panels)
    assert any(s["name"] == "right camera" for p in views.panels for s in p["series"])


def test_an_unreadable_file_is_named_once_by_its_own_section(sample, tmp_path):
    copy = open_project(shutil.copytree(sample.folder, tmp_path / "copy"))
    copy.path("measurements").write_text("pose,target\n0,marker\n")
    inputs = load_report_inputs(copy, problems=[])
    assert inputs.measurements.present and inputs.measurements.get() is None
    report = build_report(copy)
    assert [p for p in report.problems if p.startswith("measurements.csv")] == report.problems[:1]
    assert len(report.problems) == 1
    assert not next(s for s in report.sections if s.title == "Measurements").done
    assert next(s for s in report.sections if s.title == "Identification").done
