"""The report's compensation section, from the project's accuracy_map.json (the Compensation
step): the accuracy measured on the robot with the nominal and with the calibrated model, where
it was measured, the largest joint corrections, the error vectors and lengths, and the files the
step wrote. Lengths in mm, joint corrections in deg (mm for a prismatic joint)."""
from __future__ import annotations

import numpy as np

from core.compensation.accuracy_map_file import NAME as MAP_NAME, read_accuracy_map
from core.errors import RoboCalError
from core.report.inputs import ReportInputs
from core.report.document import Figure, Section, esc, not_done, num, pairs_table, panel, series, table, unreadable

TITLE = "Compensation"
PROGRAM_NAME = "corrected_program.csv"
LARGEST = 5                  # corrections listed
ARROW_SHARE = 0.3            # the longest nominal error arrow: this share of the map's extent


def _arrows(xy: np.ndarray, vectors: np.ndarray, scale: float) -> tuple[list, list]:
    """x, y of one line per arrow (target → target + scale·vector), NaN between arrows."""
    x, y = [], []
    for p, v in zip(xy, vectors):
        x += [p[0], p[0] + scale * v[0], np.nan]
        y += [p[1], p[1] + scale * v[1], np.nan]
    return x, y


def compensation_section(inputs: ReportInputs, problems: list[str]) -> Section:
    project, robot = inputs.project, inputs.robot
    path = project.folder / MAP_NAME
    if not path.is_file():
        return Section(TITLE, [not_done(f"no {MAP_NAME}: measure the accuracy map on the Compensation step")],
                       done=False)
    q_to_file = robot.q_to_file if robot is not None else np.rad2deg
    try:
        amap = read_accuracy_map(path, robot)
    except RoboCalError as exc:
        problems.append(f"{MAP_NAME}: {exc.message}")
        return Section(TITLE, [unreadable(MAP_NAME, exc.message)], done=False)
    both = amap.both
    blocks: list = [
        "<p>The controller computes with the nominal model; RoboCal sends it the joints of the calibrated "
        f"model instead. {int(both.sum())} of {amap.n} targets in the calibrated workspace were reached both "
        f"ways and the marker was measured by the cameras each time (measured on: <b>{esc(amap.measured_by)}</b>"
        + (", cancelled before the end" if amap.cancelled else "") + ").</p>",
        pairs_table([("with the nominal model", f"RMS {num(amap.rms_before_mm, 3)} mm, max {num(amap.max_before_mm, 3)} mm"),
                     ("with the calibrated model", f"RMS <b>{num(amap.rms_after_mm, 3)} mm</b>, "
                                                    f"max {num(amap.max_after_mm, 3)} mm"),
                     ("improvement factor", f"{amap.improvement:.1f}×" if np.isfinite(amap.improvement) else "—")])]
    if both.any():
        dq = np.abs(q_to_file(amap.q_after[both]) - q_to_file(amap.q_before[both]))
        largest = dq.max(axis=1)
        order = np.argsort(largest)[::-1][:LARGEST]
        index = np.flatnonzero(both)[order]
        rows = [[str(int(i) + 1), ", ".join(num(v, 1) for v in amap.targets[i]), num(largest[k], 3),
                 f"J{int(dq[k].argmax()) + 1}", num(amap.errors_before[k], 3), num(amap.errors_after[k], 3)]
                for k, i in zip(order, index)]
        blocks += ["<h3>Largest joint corrections</h3>",
                   table(["target", "x, y, z (mm, camera frame)", "largest correction (deg)", "joint",
                          "error, nominal (mm)", "error, calibrated (mm)"], rows, numeric={2, 4, 5},
                         nowrap={0, 1, 2, 3, 4, 5})]
        xy = amap.targets_base[both, :2]
        vb, va = amap.vectors_before[both, :2], amap.vectors_after[both, :2]
        span = max(float(np.ptp(xy, axis=0).max()) if len(xy) > 1 else 100.0, 50.0)
        longest = float(np.linalg.norm(vb, axis=1).max())
        m = float(max(1.0, np.floor(ARROW_SHARE * span / longest))) if longest > 0 else 1.0
        blocks.append(Figure(
            "compensation_map", "Accuracy map, nominal against calibrated model",
            f"Left: where the marker landed relative to each target, in the robot base XY plane, errors magnified "
            f"×{m:g} (mm). Right: the lengths of the 3D position errors (mm). Measured on: {amap.measured_by}.",
            [panel("points", "error vectors (base XY plane)", "x in the robot base frame (mm)",
                   "y in the robot base frame (mm)",
                   [series("target", xy[:, 0], xy[:, 1], color=6),
                    series(f"nominal model, error ×{m:g}", *_arrows(xy, vb, m), color=1, symbol="", line=True),
                    series(f"calibrated model, error ×{m:g}", *_arrows(xy, va, m), color=0, symbol="",
                           line=True)], equal_aspect=True),
             panel("histogram", "error lengths", "position error (mm)", "targets",
                   [series("nominal model", values=amap.errors_before, color=1),
                    series("calibrated model", values=amap.errors_after, color=0)], bins=20)],
            size=(900, 360)))
    written = [MAP_NAME] + [name for name in (PROGRAM_NAME,) if (project.folder / name).is_file()]
    blocks.append(f"<p>Files written by the Compensation step: {esc(', '.join(written))}.</p>")
    return Section(TITLE, blocks)
