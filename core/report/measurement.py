"""The report's measurement section, from measurements.csv and its rejects file: the measured
points in two views of the measurement (left camera) frame with the cameras, and the rejected
poses with their reasons. Positions in mm."""
from __future__ import annotations

import numpy as np

from core.errors import RoboCalError
from core.measurement.synthetic import synthetic_description
from core.project import Output
from core.report.inputs import ReportInputs
from core.report.document import Figure, Section, esc, not_done, panel, series, table, unreadable

TITLE = "Measurements"
MAX_REJECTS_LISTED = 40


def measurement_section(inputs: ReportInputs, problems: list[str]) -> Section:
    path, loaded = inputs.project.path(Output.MEASUREMENTS), inputs.measurements
    if not loaded.present:
        return Section(TITLE, [not_done("no measurements.csv in the project")], done=False)
    if loaded.error is not None:
        if not isinstance(loaded.error, RoboCalError):
            raise loaded.error
        problems.append(f"measurements.csv: {loaded.error.message}")
        return Section(TITLE, [unreadable("measurements.csv", loaded.error.message)], done=False)
    meas = loaded.value
    blocks: list = [f"<p>{meas.n_poses} poses, {meas.n_points} measured points "
                    f"(targets: {esc(', '.join(meas.target_names))}).</p>"]
    synthetic = synthetic_description(path)
    if synthetic:
        blocks.append(f"<p class='warn'><b>Synthetic:</b> {esc(synthetic)}.</p>")
    right = None
    sf = inputs.stereo.get()
    if sf is not None:
        right = -sf.R.T @ np.asarray(sf.T, dtype=float).reshape(3)       # right camera centre, left frame
    P = meas.xyz

    def view(title, i, j, xl, yl):
        s = [series("measured points", P[:, i], P[:, j], color=0)]
        s += [series("left camera", [0.0], [0.0], color=6, symbol="s")]
        if right is not None:
            s.append(series("right camera", [right[i]], [right[j]], color=1, symbol="s"))
        return panel("points", title, xl, yl, s, equal_aspect=True)

    blocks.append(Figure(
        "measurement_points", "Measured points",
        "Every measured point in the measurement frame (the left camera's: x right, y down, z forward along the "
        "optical axis; mm), seen from the cameras (x, y) and from above (x, z)"
        + (", with the two cameras (squares)." if right is not None else "; the left camera at the origin."),
        [view("seen from the cameras", 0, 1, "x (mm)", "y (mm)"), view("from above", 0, 2, "x (mm)", "z (mm)")],
        size=(900, 380)))
    blocks.append(_rejects(path, problems))
    return Section(TITLE, blocks)


def _rejects(path, problems: list[str]) -> str:
    from core.measurement.run import read_rejects, rejects_path_for

    rpath = rejects_path_for(path)
    if not rpath.is_file():
        return "<p>No pose was rejected (no rejects file).</p>"
    try:
        rejects = read_rejects(rpath)
    except (RoboCalError, OSError, ValueError) as exc:
        message = exc.message if isinstance(exc, RoboCalError) else str(exc)
        problems.append(f"{rpath.name}: {message}")
        return unreadable(rpath.name, message)
    if not rejects:
        return "<p>No pose was rejected.</p>"
    rows = [[esc(pid), esc(target), esc(reason)] for pid, (target, _q, reason) in sorted(rejects.items())]
    more = len(rows) - MAX_REJECTS_LISTED
    text = (f"<h3>Rejected poses ({len(rows)})</h3>"
            + table(["pose", "target", "reason"], rows[:MAX_REJECTS_LISTED], numeric={0}))
    return text + (f"<p class='note'>… and {more} more in {esc(rpath.name)}.</p>" if more > 0 else "")
