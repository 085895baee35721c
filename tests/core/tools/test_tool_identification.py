"""Identifying a second tool on the calibrated lab arm from its proposed poses, and checking with
the right and the wrong tool mounted."""
from __future__ import annotations

import copy
import functools

import numpy as np
import pytest
from scipy.stats import chi2

from core.errors import RoboCalError
from core.measurement.file import Measurements
from core.monitoring.check import run_check
from core.monitoring.check_poses import select_check_poses
from core.monitoring.diagnosis import TOOL, diagnose
from core.monitoring.tool_identification import (calibrated_tools, identify_tool, propose_tool_poses,
                                                 tool_poses)
from core.monitoring.uncertainty import calibration_uncertainty
from core.virtual_lab.changes import apply_change, parse_change
from core.virtual_lab.ideal_measurements import ideal_measure
from core.virtual_lab.lab import lab_options
from core.virtual_lab.tool_truth import equivalent_offset
from tests.core.tools.two_tools import SIGMA, calibrated_cell


def mounted(lab, target):
    out = copy.copy(lab)
    out.target = target
    return out


def options(lab):
    opts = lab_options(lab)
    opts.pop("robot")
    return opts


@functools.lru_cache(maxsize=1)
def identified():
    lab, model = calibrated_cell()
    unc = calibration_uncertainty(model)
    proposal = propose_tool_poses(model, "long_gripper", candidates=600, seed=0, **options(lab))
    measure = ideal_measure(mounted(lab, "long_marker"), sigma_mm=SIGMA, seed=3)
    xyz = np.array([measure(q) for q in proposal.Q])
    meas = Measurements(pose=np.arange(len(xyz)), target=["long_marker"] * len(xyz),
                        q_file=model.q_to_file(proposal.Q), xyz=xyz, Q=proposal.Q)
    return proposal, identify_tool(model, unc, "long_gripper", meas, previous="calibrated.json")


def test_the_calibration_records_the_tool_it_measured():
    _, model = calibrated_cell()
    assert model.calibration["tools"] == ["gripper"]
    assert calibrated_tools(model, calibration_uncertainty(model)) == ["gripper"]


def test_second_tool_identified_from_its_proposed_poses_within_its_predicted_sigma():
    lab, model = calibrated_cell()
    proposal, result = identified()
    assert len(proposal.Q) == tool_poses(model, "long_gripper") == 5
    axes = model.fk_many(proposal.Q)[:, :3, 2]                 # the tool's z axis at each pose
    assert np.linalg.svd(axes, compute_uv=False).min() > 0.3    # well-spread orientations, not one direction
    # the offset is a parameter of the re-identified model, whose arm the prior let move too (the
    # last frame's orientation, which the calibration's marker near the flange hardly fixes, moves
    # a target 110 mm out by tenths of a mm): its truth is in that model's tool frame
    error = result.offsets["long_marker"] - equivalent_offset(lab, result.model, "long_marker")
    assert error @ np.linalg.solve(result.covariance, error) < chi2.ppf(0.999, 3)
    assert np.linalg.norm(error) < 3 * result.sigma_mm and result.sigma_mm < 0.2
    assert result.held_out_rms_mm < 2 * np.sqrt(3) * SIGMA          # ≈ √3·σ·√(1 + 1/4) expected
    assert result.reidentification.rms_before_mm > 1.0               # the design offset was off by mm


def test_the_updated_calibration_lists_the_tool_with_its_rows_covariance_and_history():
    _, result = identified()
    cal = result.model.calibration
    assert cal["tools"] == ["gripper", "long_gripper"]
    rows = {r["name"]: r for r in cal["parameters"]}
    assert rows["long_marker.y"]["nominal"] == 15.0
    assert rows["long_marker.y"]["identified"] == pytest.approx(result.offsets["long_marker"][1])
    assert rows["long_marker.z"]["std"] == pytest.approx(result.std_mm[2])
    assert {"long_marker.x", "long_marker.y", "long_marker.z"} <= set(cal["covariance"]["parameters"])
    entry = cal["history"][-1]
    assert entry["tool"] == "long_gripper" and entry["poses"] == 5 and entry["updated"] == "calibrated.json"
    assert calibrated_tools(result.model, calibration_uncertainty(result.model)) == ["gripper", "long_gripper"]


def test_measurements_of_another_tool_are_refused():
    lab, model = calibrated_cell()
    meas = Measurements(pose=np.arange(3), target=["marker"] * 3, q_file=np.zeros((3, 6)),
                        xyz=np.zeros((3, 3)), Q=np.zeros((3, 6)))
    with pytest.raises(RoboCalError, match="not on tool 'long_gripper'"):
        identify_tool(model, calibration_uncertainty(model), "long_gripper", meas)


def check(model, lab, tool, mounted_target):
    unc = calibration_uncertainty(model)
    target = model.tool_targets(tool)[0]
    Q = select_check_poses(model, 8, candidates=500, **{**options(lab), "target": target}).Q
    measure = ideal_measure(mounted(lab, mounted_target), sigma_mm=SIGMA, seed=5)
    result = run_check(model, unc, Q, measure, target=target, tool=tool)
    return result, unc


def test_check_with_the_right_tool_is_within_limits():
    lab, _ = calibrated_cell()
    model = identified()[1].model
    result, _ = check(model, lab, "long_gripper", "long_marker")
    assert result.within and result.tool == "long_gripper", result.verdict()


def test_check_with_the_wrong_tool_leaves_its_limits_and_the_diagnosis_names_the_tool():
    lab, _ = calibrated_cell()
    model = identified()[1].model
    result, unc = check(model, lab, "gripper", "long_marker")
    assert not result.within and result.rms_mm > 50
    diagnosis = diagnose(model, unc, result)
    assert diagnosis.kind == TOOL and diagnosis.explained
    assert diagnosis.parameters[0].target == "marker" and "the tool 'gripper'" in diagnosis.text
    assert "another tool mounted" in diagnosis.text


def test_the_lab_mounts_a_tool_its_robot_defines():
    lab, _ = calibrated_cell()
    copy_ = copy.copy(lab)
    change = apply_change(copy_, "mount:long_gripper")
    assert change == parse_change("mount:long_gripper") and str(change) == "mount:long_gripper"
    assert copy_.target == "long_marker" and lab.target == "marker"
    with pytest.raises(RoboCalError, match="no tool 'drill'"):
        apply_change(copy_, "mount:drill")
