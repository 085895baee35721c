"""The parameter table of an identification: every parameter's nominal, start and identified value
with its standard deviation (mm / deg), its status and why. The base's rotations are shown as
roll, pitch, yaw (Rz·Ry·Rx, as in the robot file), their std propagated from the estimated small
rotations about the measurement frame's axes."""
from __future__ import annotations

import numpy as np

from core import transforms as tf
from core.identification.fit import Fit
from core.identification.prior import DOMINATED_SHARE, PRIOR_DOMINATED
from core.identification.result import ParameterRow
from core.kinematics.identifiability import IDENTIFIED
from core.kinematics.jacobian import COMPLIANCE, display_value
from core.robot.model import RobotModel


def _rpy_jacobian(R: np.ndarray) -> np.ndarray:
    """∂(roll, pitch, yaw)/∂ω for R ← Exp(ω)·R at ω = 0 (central differences)."""
    h = 1e-7
    E = np.zeros((3, 3))
    for k in range(3):
        w = np.zeros(3)
        w[k] = h
        d = tf.matrix_to_rpy(tf.rot_vec(w) @ R) - tf.matrix_to_rpy(tf.rot_vec(-w) @ R)
        E[:, k] = ((d + np.pi) % (2 * np.pi) - np.pi) / (2 * h)
    return E


def parameter_rows(fit: Fit, nominal: RobotModel) -> tuple[list[ParameterRow], np.ndarray]:
    """One row per parameter of g (in g's order) with its nominal, initial and identified values
    and std in file units, and the std of the estimated parameters in internal units (mm / rad)."""
    ident, model = fit.ident, fit.model
    free_index = {p.name: k for k, p in enumerate(ident.free)}
    std_int = np.sqrt(np.clip(np.diag(fit.covariance), 0.0, None))
    rot_free = [k for k, p in enumerate(ident.free) if p.group == "base" and len(p.kind) == 2]
    rpy_std = {}
    if rot_free:
        E = _rpy_jacobian(model.base[:3, :3])
        cols = ["xyz".index(ident.free[k].kind[1]) for k in rot_free]
        C = fit.covariance[np.ix_(rot_free, rot_free)]
        Es = E[:, cols]
        var = np.diag(Es @ C @ Es.T)
        rpy_std = {axis: float(np.rad2deg(np.sqrt(max(v, 0.0)))) for axis, v in zip("xyz", var)}
    rows = []
    for prm in ident.params:
        k = free_index.get(prm.name)
        excl = ident.exclusion(prm.name)
        if k is not None:
            if prm.group == "base" and len(prm.kind) == 2:
                std = rpy_std.get(prm.kind[1])
            else:
                std = float(std_int[k] * prm.to_display)
        else:
            std = None
        share = (fit.shares.get(prm.name) if fit.shares is not None and prm.group in ("joint", COMPLIANCE)
                 else None)
        status = IDENTIFIED if k is not None else excl.status
        explanation = "" if excl is None else excl.explanation
        if share is not None and share < DOMINATED_SHARE:
            status = PRIOR_DOMINATED
            explanation = (f"The measurements determine {share:.0%} of {prm.name}; the prior toward its "
                           f"nominal value determines the rest.")
        rows.append(ParameterRow(
            name=prm.name, group=prm.group, kind=prm.kind, unit=prm.unit,
            nominal=display_value(nominal, prm), initial=display_value(fit.initial, prm),
            identified=display_value(model, prm), std=std, identifiable=k is not None,
            status=status, explanation=explanation,
            partners=() if excl is None else excl.partners, data_share=share))
    return rows, std_int
