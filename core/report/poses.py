"""The report's pose sequence section, from poses.csv and the robot model: the joint values of
every pose, the condition number κ against the number of poses, and the marker positions in
two orthographic views of the model's world frame. Joint values in deg (mm for prismatic
joints), positions in mm."""
from __future__ import annotations

import numpy as np

from core.errors import RoboCalError
from core.poses.selection import indices_from_eigenvalues, minimum_poses, random_indices, scaled_blocks
from core.project import Output, Project
from core.report.inputs import ReportInputs
from core.report.document import Figure, Section, esc, not_done, panel, series, sig, unreadable
from core.robot.model import RobotModel

TITLE = "Pose sequence"
RANDOM_TRIALS = 50


def poses_section(inputs: ReportInputs, problems: list[str]) -> Section:
    project, robot = inputs.project, inputs.robot
    path = project.path(Output.POSES)
    if not path.is_file():
        return Section(TITLE, [not_done("no poses.csv in the project")], done=False)
    from core.poses.file import read_poses
    try:
        poses = read_poses(path, robot)
    except RoboCalError as exc:
        problems.append(f"poses.csv: {exc.message}")
        return Section(TITLE, [unreadable("poses.csv", exc.message)], done=False)
    n = len(poses)
    blocks: list = [f"<p>{n} poses in poses.csv, in the order the robot visits them.</p>"]
    x = np.arange(n)
    names = ([j.name or f"J{i + 1}" for i, j in enumerate(robot.joints)] if robot is not None
             else [f"q{i + 1}" for i in range(poses.q_file.shape[1])])
    blocks.append(Figure("poses_joints", "Joint values",
                         "The joint values of each pose of the sequence (deg; mm for a prismatic joint).",
                         [panel("points", "", "pose (visiting order)", "joint value (deg)",
                                [series(str(name), x, poses.q_file[:, j], color=j, line=True)
                                 for j, name in enumerate(names)], x_ticks=None)]))
    if robot is None or poses.Q is None:
        why = "the project has no robot model"
        blocks += [Figure("poses_index", "Condition number against the number of poses", "", unavailable=why),
                   Figure("poses_views", "Marker positions", "", unavailable=why)]
        return Section(TITLE, blocks)
    target = "marker" if "marker" in robot.targets else next(iter(robot.targets), None)
    if target is None:
        why = "the robot model defines no target point"
        blocks += [Figure("poses_index", "Condition number against the number of poses", "", unavailable=why),
                   Figure("poses_views", "Marker positions", "", unavailable=why)]
        return Section(TITLE, blocks)
    blocks.append(_index_curve(robot, poses.Q, target))
    P = robot.target_positions(poses.Q, target)
    b = robot.base[:3, 3]
    cams = _cameras_in_world(project, robot, inputs.stereo.get())
    where = ("; the squares are the two cameras, placed by the calibrated model's base" if cams is not None
             else " (the cameras are drawn once the project has a calibrated model)")

    def view(title: str, k: int) -> dict:
        out = [series("marker", P[:, 0], P[:, k], color=0), series("base", [b[0]], [b[k]], color=6, symbol="+")]
        if cams is not None:
            out.append(series("cameras (left, right)", cams[:, 0], cams[:, k], color=3, symbol="s"))
        return panel("points", title, "x (mm)", f"{'yz'[k - 1]} (mm)", out, equal_aspect=True)

    blocks.append(Figure(
        "poses_views", "Marker positions",
        f"Where the nominal model puts the target '{target}' at each pose, in the model's world frame (mm), "
        f"seen from above and from the side; the black cross is the robot's base{where}.",
        [view("top view", 1), view("side view", 2)], size=(900, 380)))
    return Section(TITLE, blocks)


def _cameras_in_world(project: Project, robot: RobotModel, stereo) -> np.ndarray | None:
    """The left and right camera centres (2, 3) in the nominal model's world frame (mm), through
    the calibrated model's base (robot base in the left camera frame); None without both files."""
    if stereo is None or not project.has(Output.CALIBRATED):
        return None
    from core.robot.file import read_robot
    try:
        base_in_camera = read_robot(project.path(Output.CALIBRATED)).base
    except RoboCalError:
        return None                       # the identification section names the unreadable file
    centres = np.array([np.zeros(3), -stereo.R.T @ stereo.T])          # left camera frame
    world_from_camera = robot.base @ np.linalg.inv(base_in_camera)
    return centres @ world_from_camera[:3, :3].T + world_from_camera[:3, 3]


def _index_curve(robot: RobotModel, Q: np.ndarray, target: str) -> Figure:
    title = "Condition number against the number of poses"
    A, names, _scales, _ident = scaled_blocks(robot, Q, [target])
    G = np.einsum("nki,nkj->nij", A, A)
    M = len(Q)
    n_min = minimum_poses(robot, [target])
    if M < n_min:
        return Figure("poses_index", title, "", unavailable=f"{M} poses, fewer than the {n_min} that "
                                                            f"{len(names)} parameters need")
    ns = np.arange(n_min, M + 1)
    prefix = [float(indices_from_eigenvalues(np.linalg.eigvalsh(G[:k].sum(axis=0)), k)["cond"]) for k in ns]
    rng = np.random.default_rng(0)
    rand = [float(np.median(random_indices(G, int(k), RANDOM_TRIALS, rng)["cond"])) for k in ns]
    finite = [(k, v) for k, v in zip(ns, prefix) if np.isfinite(v)]
    return Figure(
        "poses_index", title,
        f"κ of the scaled identification Jacobian ({len(names)} parameters; lower is better) of the first N poses "
        f"of the sequence (what a measurement run stopped after N poses gives), beside the median of "
        f"{RANDOM_TRIALS} random sets of N of the same poses. All {M} poses: κ = {esc(sig(prefix[-1], 3))}.",
        [panel("points", "", "number of poses N", "condition number κ",
               [series("first N of the sequence", [k for k, _ in finite], [v for _, v in finite], color=0,
                       line=True),
                series(f"random N of them (median of {RANDOM_TRIALS})", ns,
                       [v if np.isfinite(v) else np.nan for v in rand], color=1, line=True, symbol="t")],
               log_y=True)])
