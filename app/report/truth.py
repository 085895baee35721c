"""The accuracy against the virtual lab's true robot for a report made from the project files
(the wizard hands in the one it computed). The lab is the wizard's (seed 0, noise 0.5: a
WizardState's defaults), so the true robot is the one the project's measurements came from."""
from __future__ import annotations

import numpy as np

from app.lab import build_lab
from app.jobs.identification import TRUTH_POSES
from core.errors import RoboCalError
from core.identification.model_comparison import TruthAccuracy, accuracy_against_truth
from core.identification.fit import register_base
from core.identification.validation import split_poses
from core.measurement.file import read_measurements
from core.project import Output, Project, VIRTUAL_LAB, load_robot
from core.robot.file import read_robot

LAB_SEED, LAB_NOISE = 0, 0.5


def project_truth_accuracy(project: Project, *, robot=None, lab_seed: int = LAB_SEED) -> TruthAccuracy | None:
    """Nominal (base registered on the fitted poses) and calibrated model against the true robot
    at TRUTH_POSES fresh visible poses, as the Identification step computes it; None for a
    hardware project or one without robot, measurements and calibrated model (or unreadable).
    `robot`: the nominal model (else the project's); `lab_seed`: the lab's (a dataset's truth.json)."""
    if project.mode != VIRTUAL_LAB or not (project.has(Output.CALIBRATED) and project.has(Output.MEASUREMENTS)):
        return None
    try:
        robot = robot if robot is not None else load_robot(project)
        if robot is None:
            return None
        model = read_robot(project.path(Output.CALIBRATED))
        meas = read_measurements(project.path(Output.MEASUREMENTS), robot)
        v = ((model.calibration or {}).get("statistics") or {}).get("validation") or {}
        seed = int(v.get("seed", 0))
        test = set(v.get("test_poses") or (split_poses(meas.pose_ids, float(v["fraction"]), seed)[1]
                                           if v.get("method") == "holdout" else []))
        initial = register_base(robot, meas.select_poses([p for p in meas.pose_ids if p not in test]))
        lab = build_lab(robot, lab_seed, LAB_NOISE)
        Q = lab.random_visible_poses(TRUTH_POSES, np.random.default_rng([seed, 6]))
        return accuracy_against_truth(lab.true_robot, initial, model, Q, [lab.target])
    except (RoboCalError, KeyError, TypeError, ValueError):
        return None
