"""The report's part on the deflection under the arm's weight (joint compliance), within the
identification section: what identification chose and why (calibration.statistics.compliance),
the payload mounted during calibration, and — when the calibrated model has deflection terms —
the joint-angle corrections δq2 and δq3 (deg) it applies at each measured pose, against the
pose number and against q2 (deg), and how far they move the tool point measured at each pose
(mm, measurement frame): the length of the displacement and its part along gravity (down)."""
from __future__ import annotations

import numpy as np

from core.report.document import Figure, esc, panel, series
from core.robot.model import RobotModel

FIGURE = "identification_deflection"
TITLE = "Deflection under the arm's weight"


def _payload_text(calibration: dict, terms: bool) -> str:
    kg = calibration.get("payload_kg")
    if kg is None:
        return ("Payload during calibration: not recorded" + ("; the deflection terms hold for whatever was "
                                                              "mounted then." if terms else "."))
    return f"Payload during calibration: {float(kg):g} kg" + (
        " — the deflection terms hold for this payload; a heavier tool bends the arm more." if terms else ".")


def deflection_blocks(calibration: dict, model: RobotModel, meas) -> list:
    """The blocks of the deflection part: nothing when identification was not asked for the terms
    (--compliance off) and no payload is recorded, one line for a rigid model, and the verdict, the payload and the
    figure for a model with terms. `meas`: the project's measurements (None: figure unavailable)."""
    choice = (calibration.get("statistics") or {}).get("compliance")
    verdict = choice.get("verdict") if isinstance(choice, dict) else None
    terms = model.compliance is not None and not model.compliance.is_zero
    if not terms:
        asked = isinstance(choice, dict) and choice.get("mode") not in (None, "off")
        if not asked and calibration.get("payload_kg") is None:
            return []
        words = " ".join(w for w in (verdict, _payload_text(calibration, False)) if w)
        return [f"<p><b>{TITLE}:</b> {esc(words)}</p>"]
    blocks = [f"<h3>{TITLE}</h3><p>{esc(verdict or 'The calibrated model has deflection terms.')} "
              f"{esc(_payload_text(calibration, True))}</p>"]
    blocks.append(_figure(model, meas))
    return blocks


def _tool_displacement(model: RobotModel, Q: np.ndarray, targets: list[str]) -> tuple[np.ndarray, np.ndarray]:
    """How far the deflection moves each tool point: (length (N,), part along gravity, down
    positive (N,)), mm, in the measurement frame — the calibrated model's point with its
    deflection minus the same model's rigid point at the same joint values Q (N, n; rad)."""
    rigid = model.copy()
    rigid.compliance = None
    delta = np.array([model.target_position(q, t) - rigid.target_position(q, t) for q, t in zip(Q, targets)])
    down = model.base[:3, :3] @ model.compliance.gravity
    return np.linalg.norm(delta, axis=1), delta @ (down / np.linalg.norm(down))


def _figure(model: RobotModel, meas) -> Figure:
    if meas is None:
        return Figure(FIGURE, "Joint-angle corrections of the deflection", "",
                      unavailable="needs the project's measurements.csv (the calibration's poses)")
    meas = meas if meas.Q is not None and meas.Q.shape[1] == model.dof else meas.with_robot(model)
    ids = meas.pose_ids
    rows = [int(np.flatnonzero(meas.pose == p)[0]) for p in ids]
    Q = np.asarray(meas.Q, dtype=float)[rows]
    dq = np.rad2deg(model.compliance.deflection(Q))             # deg, (poses, n)
    q2 = np.rad2deg(Q[:, 1])
    x = [int(p) for p in ids]
    order = np.argsort(q2)
    points = [meas.target[i] if meas.target[i] in model.targets else next(iter(model.targets)) for i in rows]
    length, sag = _tool_displacement(model, Q, points)
    named = ", ".join(dict.fromkeys(points))
    return Figure(
        FIGURE, "Joint-angle corrections of the deflection and the tool point's displacement",
        "How far the shoulder (J2) and elbow (J3) stand from the angles the controller reports because the arm "
        "bends under its weight and payload, as the calibrated model's deflection terms give it, at each pose of "
        f"the calibration's measurements ({len(x)} poses). Left: against the pose number; middle: against the "
        f"shoulder angle q2; right: how far these corrections move the tool point measured at each pose ({named}) "
        f"— the length of the displacement (largest {float(length.max()):.3f} mm) and its part along gravity "
        "(positive: down).",
        [panel("points", "by pose", "pose", "correction (deg)",
               [series("δq2 (shoulder J2)", x, dq[:, 1], color=0),
                series("δq3 (elbow J3)", x, dq[:, 2], color=1, symbol="t")], hlines=((0.0, "rigid arm"),)),
         panel("points", "against the shoulder angle", "q2 (deg)", "correction (deg)",
               [series("δq2 (shoulder J2)", q2[order], dq[order, 1], color=0),
                series("δq3 (elbow J3)", q2[order], dq[order, 2], color=1, symbol="t")], hlines=((0.0, "rigid arm"),)),
         panel("points", "tool point displacement", "pose", "displacement (mm)",
               [series("length |Δp| (mm)", x, length, color=2),
                series("along gravity, down (mm)", x, sag, color=3, symbol="s")], hlines=((0.0, "rigid arm"),))])
