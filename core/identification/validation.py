"""Validation over poses: errors on measurements the fit did not see (mm).

* hold-out: a seeded random fraction of the poses is held out (`split_poses`); the model is
  fitted on the others and predicts them (`holdout_validation`);
* k-fold: the poses split into k seeded random groups (`kfold_poses`), each predicted by a model
  fitted on the others (`kfold_validation`);
* the deflection terms: kept only when cross validation over poses shows a gain
  (`select_compliance`, decided by core.identification.compliance_selection).
"Before" is the nominal geometry with its base registered on the training poses.
"""
from __future__ import annotations

from typing import Sequence

import numpy as np

from core.errors import RoboCalError, UsageError
from core.identification.compliance_selection import AUTO, ComplianceChoice, cross_validate, decide
from core.identification.compliance_selection import FOLDS as COMPLIANCE_FOLDS
from core.identification.fit import error_stats, fit_model, register_base
from core.identification.prior import Weights
from core.identification.result import Validation, merge_stats
from core.measurement.file import Measurements
from core.robot.model import RobotModel
from core.task import Monitor


def split_poses(pose_ids: Sequence[int], fraction: float, seed: int = 0) -> tuple[list[int], list[int]]:
    """(training, test) pose ids: a seeded random `fraction` of the poses is held out."""
    ids = list(pose_ids)
    if not 0.0 < fraction < 1.0:
        raise UsageError(f"the held-out fraction must be between 0 and 1, got {fraction}")
    n_test = int(round(fraction * len(ids)))
    n_test = min(max(n_test, 1), len(ids) - 1)
    rng = np.random.default_rng(seed)
    test = set(rng.choice(len(ids), size=n_test, replace=False).tolist())
    return [p for k, p in enumerate(ids) if k not in test], [p for k, p in enumerate(ids) if k in test]


def kfold_poses(pose_ids: Sequence[int], folds: int, seed: int = 0) -> list[list[int]]:
    """The pose ids split into `folds` seeded random groups of (nearly) equal size."""
    ids = list(pose_ids)
    if folds < 2 or folds > len(ids):
        raise UsageError(f"k-fold needs 2 ≤ k ≤ number of poses ({len(ids)}), got {folds}")
    order = np.random.default_rng(seed).permutation(len(ids))
    return [[ids[k] for k in sorted(part)] for part in np.array_split(order, folds)]


def holdout_validation(robot: RobotModel, fitted: RobotModel, train: Measurements, test: Measurements,
                       test_ids: Sequence[int], *, fraction: float, seed: int) -> Validation:
    """Errors on the held-out poses `test` (ids `test_ids`): before, the nominal `robot` with its
    base registered on the training poses `train`; after, the model `fitted` on them."""
    before = error_stats(register_base(robot, train), test)
    return Validation("holdout", before=before, after=error_stats(fitted, test),
                      test_poses=[int(p) for p in test_ids], fraction=float(fraction), seed=seed)


def kfold_validation(robot: RobotModel, meas: Measurements, folds: Sequence[Sequence[int]], fit_options: dict,
                     monitor: Monitor, *, seed: int) -> Validation:
    """k-fold cross validation over poses: every fold of `folds` (pose ids) predicted by a model
    fitted on the other folds (`fit_model(robot, …, **fit_options)`), and by the nominal `robot`
    with its base registered on them."""
    kfold = len(folds)
    befores, afters, rms = [], [], []
    for k, test_ids in enumerate(folds):
        sub = monitor.sub(k / kfold, (k + 1) / kfold)
        sub.step(0.0, f"cross validation: fold {k + 1} of {kfold}")
        tr = meas.select_poses([p for p in meas.pose_ids if p not in set(test_ids)])
        te = meas.select_poses(test_ids)
        try:
            f = fit_model(robot, tr, monitor=sub, **fit_options)
        except RoboCalError as exc:
            raise RoboCalError(f"cross validation fold {k + 1} of {kfold}: {exc.problem}",
                               source=exc.source, hint=exc.hint or
                               "Use fewer folds or measure more poses.") from exc
        befores.append(error_stats(register_base(robot, tr), te))
        afters.append(error_stats(f.model, te))
        rms.append(afters[-1].rms_mm)
    return Validation("kfold", before=merge_stats(befores), after=merge_stats(afters),
                      test_poses=[int(p) for p in meas.pose_ids], folds=int(kfold), seed=seed,
                      fold_rms_mm=rms)


def select_compliance(rigid: RobotModel, robot: RobotModel, train: Measurements, kw: dict, w_off: Weights,
                      w_on: Weights, seed: int, monitor: Monitor) -> ComplianceChoice:
    """Cross validation grouped by pose of the fits without and with the deflection terms (their
    weights kept), decided by the one-standard-error rule."""
    n = len(train.pose_ids)
    try:
        folds = kfold_poses(train.pose_ids, min(COMPLIANCE_FOLDS, n), seed)
        off, on = cross_validate(
            lambda tr, m: fit_model(rigid, tr, monitor=m, prior_weights=w_off, **kw).model,
            lambda tr, m: fit_model(robot, tr, monitor=m, prior_weights=w_on, compliance=True, **kw).model,
            train, folds, monitor=monitor)
    except (RoboCalError, UsageError) as exc:
        return ComplianceChoice(AUTO, False, f"Too few poses to test the deflection terms ({n}: "
                                f"{exc.problem}); geometry only.")
    if len(off) < 3:
        return ComplianceChoice(AUTO, False, f"Too few poses to test the deflection terms ({len(off)} could be "
                                f"predicted); geometry only.")
    return decide(off, on, len(folds), w_on.compliance)
