"""The virtual lab: a robot with known true geometry in front of two simulated cameras.

`VirtualLab.create(...)` builds the scene; the rest of the app uses its attributes (`rig`,
`nominal_robot`, `true_robot`, `board`, `marker`) and its methods to choose board poses and
robot configurations and to render image pairs. The world frame is the left camera frame
(mm). The robot stands on a table in front of the cameras (base z up = −y of the camera,
base x towards the cameras), below the optical axis, placed according to its reach so that
the marker is seen at 400–900 mm in its visible configurations.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from core import transforms as tf
from core.stereo.board import Board
from core.camera import CameraModel
from core.errors import RoboCalError
from core.robot.model import RobotModel, robot_path
from core.robot.file import read_robot
from core.stereo.rig import StereoRig
from core.virtual_lab.background import Room, seeded_room
from core.virtual_lab.conditions import ImagingConditions, draw_occluder
from core.marker.description import MarkerDescription
from core.virtual_lab.renderer import ImageComposer, PlateTexture
from core.virtual_lab.rig import default_rig, right_from_left
from core.virtual_lab.robot_errors import RobotErrors, perturb_robot
from core.virtual_lab.robot_deflection import deflecting_robot
from core.robot.compliance import check_vertical_arm
from core.poses.candidates import VisibilityOptions
from core.poses.visibility import marker_visibility

DEFAULT_ROBOT = "educational_6r"
DEFAULT_BOARD = Board(9, 6, 25.0)      # fits both views fully from ~500 mm to 1100 mm
MARKER_TARGET = "marker"
BOARD_DEPTH = (500.0, 1100.0)          # mm
BOARD_MAX_TILT = 40.0                  # deg
BOARD_MARGIN_PX = 8.0
POSE_DEPTH = (400.0, 900.0)            # mm, marker depth of the random visible poses
TRAINING_SIZE = 480                    # px, square training image
TRAINING_DISTANCE = 300.0              # mm (5 px/mm with f = 1500 px)
TRAINING_FOCAL = 1500.0
MARKER_BLACK, MARKER_WHITE = 22.0, 218.0


def robot_reach(robot: RobotModel, target: str = MARKER_TARGET) -> float:
    """Upper bound of the distance from the base to the target (mm): sum of link lengths."""
    p = robot.dh_arrays()
    reach = float(np.sum(np.abs(p["a"]) + np.abs(p["d"])))
    reach += float(np.linalg.norm(robot.tool[:3, 3]))
    if target in robot.targets:
        reach += float(np.linalg.norm(robot.targets[target]))
    return reach


def base_placement(robot: RobotModel, rig: StereoRig) -> np.ndarray:
    """Pose of the robot base in the left camera frame (4x4), scaled with the robot's reach:
    base z up (camera −y), base x towards the cameras (camera −z), between the cameras,
    below the optical axis."""
    reach = robot_reach(robot)
    R = np.column_stack([[0.0, 0.0, -1.0], [1.0, 0.0, 0.0], [0.0, -1.0, 0.0]])
    x = 0.5 * float(rig.right_centre[0])
    depth = 560.0 + 0.3 * reach
    below = 0.5 * reach
    return tf.make_transform(R, [x, below, depth])


def table_level(robot: RobotModel) -> float:
    """Height of the mounting surface in the base frame (mm): 0 when the base frame sits on it
    (the first joint's d models the column), else a pedestal below a shoulder-level base
    frame (as the PUMA 560's), 0.45 of the reach down."""
    d1 = abs(robot.joints[0].d) if robot.joints[0].revolute else 0.0
    return 0.0 if d1 >= 0.05 * robot_reach(robot) else -0.45 * robot_reach(robot)


def _rng(rng) -> np.random.Generator:
    return rng if isinstance(rng, np.random.Generator) else np.random.default_rng(rng)


@dataclass
class Lighting:
    gradient: float
    angle: float
    exposure_left: float
    exposure_right: float

    @classmethod
    def draw(cls, rng: np.random.Generator) -> "Lighting":
        exposure = rng.uniform(0.95, 1.05)
        return cls(float(rng.uniform(0.0, 0.15)), float(rng.uniform(0.0, 2 * np.pi)),
                   float(exposure), float(exposure * rng.uniform(0.98, 1.02)))


class VirtualLab:
    """Stereo rig, robot (nominal and true), checkerboard, marker and room of the virtual lab."""

    def __init__(self, rig: StereoRig, nominal_robot: RobotModel, true_robot: RobotModel, board: Board,
                 marker: MarkerDescription, room: Room, *, errors: RobotErrors, base_error: np.ndarray,
                 noise: float = 0.5, seed: int = 0, target: str = MARKER_TARGET):
        self.rig = rig
        self.nominal_robot = nominal_robot
        self.true_robot = true_robot
        self.board = board
        self.marker = marker
        self.room = room
        self.errors = errors
        self.base_error = base_error          # true base = nominal base · base_error
        self.noise = float(noise)
        self.seed = seed
        self.target = target
        self._right_from_left = right_from_left(rig)
        self._texture: PlateTexture | None = None
        self._reach = robot_reach(nominal_robot)
        self._table = table_level(nominal_robot)

    # -- construction -------------------------------------------------------------------
    @classmethod
    def create(cls, robot: RobotModel | str | None = None, seed: int = 0, noise: float = 0.5,
               board: Board | None = None, marker: MarkerDescription | None = None,
               rig: StereoRig | None = None, deflection: bool = False) -> "VirtualLab":
        """A lab, fully determined by `seed`.

        With `deflection` the true robot also bends under its weight (seeded deflection
        coefficients, core.virtual_lab.robot_deflection; the robot must be a vertical arm) — what
        the deflection terms of identification (--compliance) estimate; the nominal robot is rigid.

        `robot` is a nominal model (copied; its base is replaced by the placement in front of
        the cameras, its tool is kept), a robot file path, or None for the educational 6R
        preset. Without a "marker" target, one is added 25 mm along the tool z axis."""
        if robot is None:
            robot = read_robot(robot_path(DEFAULT_ROBOT))
        elif not isinstance(robot, RobotModel):
            robot = read_robot(robot)
        nominal = robot.copy()
        if MARKER_TARGET not in nominal.targets:
            nominal.targets[MARKER_TARGET] = np.array([0.0, 0.0, 25.0])
        streams = np.random.SeedSequence(int(seed)).spawn(5)     # the first four as before a fifth existed
        rig = rig if rig is not None else default_rig(np.random.default_rng(streams[0]))
        nominal.base = base_placement(nominal, rig)
        errors = perturb_robot(nominal, np.random.default_rng(streams[1]))
        true = errors.robot
        if deflection:
            check_vertical_arm(nominal, field="deflection")
            true = deflecting_robot(true, np.random.default_rng(streams[4]))
        rng = np.random.default_rng(streams[2])
        axis = rng.normal(size=3)
        offset = rng.normal(size=3)
        base_error = tf.make_transform(
            tf.rot_axis(axis / np.linalg.norm(axis), np.deg2rad(rng.uniform(0.2, 0.5))),
            offset / np.linalg.norm(offset) * rng.uniform(2.0, 5.0))
        true.base = nominal.base @ base_error
        marker = marker if marker is not None else MarkerDescription.default()
        table_y = float((nominal.base @ tf.make_transform(None, [0.0, 0.0, table_level(nominal)]))[1, 3])
        room = seeded_room(streams[3], rig,
                           wall_depth=max(2500.0, float(nominal.base[2, 3]) + 1.5 * robot_reach(nominal)),
                           table_height=table_y)
        return cls(rig, nominal, true, board or DEFAULT_BOARD, marker, room, errors=errors,
                   base_error=base_error, noise=noise, seed=seed)

    # -- geometry -----------------------------------------------------------------------
    @property
    def plate_size(self) -> tuple[float, float]:
        return tuple(self.marker.plate_size)

    def marker_position(self, q) -> np.ndarray:
        """True 3D marker reference point (mm, left camera frame) for joint values q (rad)."""
        return self.true_robot.target_position(np.asarray(q, dtype=float), self.target)

    def marker_pose(self, q) -> np.ndarray:
        """4x4 pose of the marker plate frame in the left camera frame (true robot)."""
        T = self.true_robot.fk(np.asarray(q, dtype=float))
        return T @ tf.make_transform(None, self.true_robot.targets[self.target])

    def visibility(self, Q, **options):
        """core.poses.visibility.marker_visibility for the true robot and the lab's marker plate."""
        return marker_visibility(Q, self.true_robot, self.rig, self.plate_size, target=self.target, **options)

    def random_visible_poses(self, n: int, rng=None, *, max_tries: int = 400, **visibility_options) -> np.ndarray:
        """n joint configurations (n, dof) in rad/mm, inside the joint limits (1° margin),
        rounded to 0.001° (as a controller reports them), where the marker is visible to
        both cameras (core.poses.visibility with depth 400–900 mm unless given) and every joint
        frame stays above the table."""
        rng = _rng(rng)
        visibility_options.setdefault("min_depth", POSE_DEPTH[0])
        visibility_options.setdefault("max_depth", POSE_DEPTH[1])
        robot = self.true_robot
        lo, hi = robot.sampling_range(1.0)
        found: list[np.ndarray] = []
        for _ in range(max_tries):
            if len(found) >= n:
                break
            Q = rng.uniform(lo, hi, (2048, robot.dof))
            Q = robot.q_from_file(np.round(robot.q_to_file(Q), 3))
            ok = self.visibility(Q, **visibility_options).visible & self._above_table(Q)
            found.extend(Q[ok][: n - len(found)])
        if len(found) < n:
            raise RoboCalError(f"found only {len(found)} of {n} configurations of {robot.name} where both "
                               f"cameras see the marker", hint="Check the robot's joint limits and its marker "
                               "target (the marker must face the cameras in some poses).")
        return np.array(found[:n]).reshape(n, robot.dof)

    def _above_table(self, Q, clearance: float = 15.0) -> np.ndarray:
        F = self.true_robot.frames_many(Q)
        base_inv = tf.invert(self.true_robot.base)
        z = np.einsum("j,nkj->nk", base_inv[2, :3], F[:, 1:, :3, 3]) + base_inv[2, 3]
        marker = self.true_robot.target_positions(Q, self.target) @ base_inv[:3, :3].T + base_inv[:3, 3]
        return np.all(z > self._table + clearance, axis=1) & (marker[:, 2] > self._table + clearance + 20.0)

    def random_board_poses(self, n: int, rng=None, *, candidates_per_pose: int = 30) -> list[np.ndarray]:
        """n well-spread checkerboard poses (4x4, board frame -> left camera frame) fully
        visible in both cameras (white margin included): distance 500–1100 mm, anywhere in
        the view, tilted up to ~40°, rolled up to ±25° — like a person waving a board.
        Chosen from random candidates by farthest-point sampling of (position, distance, tilt)."""
        rng = _rng(rng)
        b = self.board
        pool_T, pool_f = [], []
        tries = 0
        while sum(len(t) for t in pool_T) < max(n * candidates_per_pose, 50) and tries < 200:
            tries += 1
            T, feats = self._board_candidates(rng, 512)
            pool_T.append(T)
            pool_f.append(feats)
        T = np.concatenate(pool_T)
        F = np.concatenate(pool_f)
        if len(T) < n:
            raise RoboCalError(f"found only {len(T)} of {n} poses of the {b.cols}x{b.rows} board that both "
                               f"cameras see whole", hint="Use a smaller board (fewer or smaller squares).")
        chosen = [int(rng.integers(len(T)))]
        dist = np.linalg.norm(F - F[chosen[0]], axis=1)
        while len(chosen) < n:
            i = int(np.argmax(dist))
            chosen.append(i)
            dist = np.minimum(dist, np.linalg.norm(F - F[i], axis=1))
        return [T[i].copy() for i in chosen]

    def _board_outline(self) -> np.ndarray:
        b = self.board
        lo = -2.0 * b.square
        return np.array([[lo, lo, 0], [(b.cols + 1) * b.square, lo, 0],
                         [(b.cols + 1) * b.square, (b.rows + 1) * b.square, 0], [lo, (b.rows + 1) * b.square, 0]])

    def _board_candidates(self, rng: np.random.Generator, m: int):
        b = self.board
        cam = self.rig.left
        depth = rng.uniform(*BOARD_DEPTH, m)
        uv = np.stack([rng.uniform(0, cam.width, m), rng.uniform(0, cam.height, m)], axis=1)
        xy = cam.pixels_to_normalized(uv)
        centre = np.concatenate([xy * depth[:, None], depth[:, None]], axis=1)
        roll = np.deg2rad(rng.uniform(-25.0, 25.0, m))
        tilt = np.deg2rad(BOARD_MAX_TILT) * np.sqrt(rng.uniform(0.0, 1.0, m))
        phi = rng.uniform(0.0, 2 * np.pi, m)
        outline = self._board_outline()
        mid = np.array([(b.cols - 1) * b.square / 2, (b.rows - 1) * b.square / 2, 0.0])
        Ts, P, Pr = [], [], []
        for i in range(m):
            axis = np.array([np.cos(phi[i]), np.sin(phi[i]), 0.0])
            R = tf.rot_axis(axis, tilt[i]) @ tf.rot_z(roll[i])
            Ts.append(tf.make_transform(R, centre[i] - R @ mid))
            P.append(tf.transform_points(Ts[-1], outline))
            Pr.append(self.rig.to_right(P[-1]))
        # Both views of the outlines in front of the cameras, projected together (row by row, as
        # one at a time gives them).
        P, Pr = np.array(P), np.array(Pr)
        front = np.flatnonzero(~np.any(P[:, :, 2] < 100.0, axis=1))
        seen = np.zeros(m, bool)
        if front.size:
            left, right = self.rig.left, self.rig.right
            seen[front] = (left.in_image(left.project(P[front].reshape(-1, 3)), BOARD_MARGIN_PX).reshape(-1, 4).all(1)
                           & right.in_image(right.project(Pr[front].reshape(-1, 3)), BOARD_MARGIN_PX)
                           .reshape(-1, 4).all(1))
        keep = np.flatnonzero(seen)
        feats = [[uv[i, 0] / cam.width, uv[i, 1] / cam.height,
                  (depth[i] - BOARD_DEPTH[0]) / (BOARD_DEPTH[1] - BOARD_DEPTH[0]),
                  np.sin(tilt[i]) * np.cos(phi[i]) * 1.5, np.sin(tilt[i]) * np.sin(phi[i]) * 1.5] for i in keep]
        return np.array([Ts[i] for i in keep]).reshape(-1, 4, 4), np.array(feats).reshape(-1, 5)

    # -- rendering ----------------------------------------------------------------------
    @property
    def marker_texture(self) -> PlateTexture:
        if self._texture is None:
            m = self.marker
            corners = m.plate_corners()
            rect = (corners[:, 0].min(), corners[:, 0].max(), corners[:, 1].min(), corners[:, 1].max())
            outer = m.outer_corners()
            square = (outer[:, 0].min(), outer[:, 0].max(), outer[:, 1].min(), outer[:, 1].max())
            self._texture = PlateTexture.from_image(m.load_image(), m.px_per_mm, m.reference_px, rect,
                                                    black=MARKER_BLACK, white=MARKER_WHITE, sign_y=-1.0,
                                                    square=square)
        return self._texture

    def _composers(self) -> tuple[ImageComposer, ImageComposer]:
        """Composers for both cameras, starting from the room (drawn once per rig: Room.canvases)."""
        left = ImageComposer(self.rig.left, None)
        right = ImageComposer(self.rig.right, self._right_from_left)
        left.canvas[...], right.canvas[...] = self.room.canvases(self.rig)
        return left, right

    def _finish(self, left: ImageComposer, right: ImageComposer, rng, noise,
                gain: float = 1.0) -> tuple[np.ndarray, np.ndarray]:
        """Both images finished; `gain` scales the scene's light (the sensor noise stays)."""
        rng = _rng(rng)
        noise = self.noise if noise is None else float(noise)
        light = Lighting.draw(rng)
        a = left.finish(rng, noise, gradient=light.gradient, gradient_angle=light.angle,
                        exposure=light.exposure_left * gain)
        b = right.finish(rng, noise, gradient=light.gradient, gradient_angle=light.angle,
                         exposure=light.exposure_right * gain)
        return a, b

    def _draw_robot(self, composers, q) -> None:
        robot = self.true_robot
        F = robot.frames_many(np.asarray(q, dtype=float)[None, :])[0]
        origins = F[:, :3, 3]
        radius = float(np.clip(0.035 * self._reach, 10.0, 60.0))
        starts, ends, radii, shades = [], [], [], []
        up = robot.base[:3, 2]
        starts.append(origins[0] + up * (self._table - 5.0))
        ends.append(origins[0] + up * (0.08 * self._reach if self._table == 0.0 else 0.0))
        radii.append(2.2 * radius)
        shades.append(55.0)
        for i in range(len(origins) - 1):
            if np.linalg.norm(origins[i + 1] - origins[i]) > 1.0:
                starts.append(origins[i])
                ends.append(origins[i + 1])
                radii.append(radius * (1.0 - 0.35 * i / len(origins)))
                shades.append(95.0 if i % 2 == 0 else 75.0)
        marker = self.marker_position(q)
        starts.append(origins[-1])
        ends.append(marker)
        radii.append(0.5 * radius)
        shades.append(60.0)
        for c in composers:
            c.draw_bars(np.array(starts), np.array(ends), np.array(radii), np.array(shades))

    def render_checkerboard_pair(self, pose: np.ndarray, rng=None, *, noise: float | None = None,
                                 robot_q=None) -> tuple[np.ndarray, np.ndarray]:
        """Left and right uint8 images of the lab's checkerboard at `pose` (4x4, board frame ->
        left camera frame), in the room, with the robot standing behind it (at `robot_q`,
        default all joints at 0 within their limits)."""
        left, right = self._composers()
        if robot_q is None:
            lo, hi = self.true_robot.limits()
            robot_q = np.clip(np.zeros(self.true_robot.dof), lo, hi)
        self._draw_robot((left, right), robot_q)
        for c in (left, right):
            c.draw_checkerboard(self.board, pose)
        return self._finish(left, right, rng, noise)

    def render_marker_pair(self, q, rng=None, *, noise: float | None = None,
                           conditions: ImagingConditions | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Left and right uint8 images of the robot (true geometry) at joint values q (rad/mm)
        carrying the marker, in the room (light and occlusion of `conditions`, if given)."""
        left, right = self._composers()
        self._draw_robot((left, right), q)
        return self._plate_pair(left, right, self.marker_pose(q), rng, noise, conditions)

    def render_marker_at(self, pose: np.ndarray, rng=None, *, noise: float | None = None,
                         background: bool = True,
                         conditions: ImagingConditions | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Left and right images of the marker plate alone at an arbitrary pose (4x4, marker
        plate frame -> left camera frame), over the room (or a plain grey background), with
        the light and occlusion of `conditions`, if given."""
        if background:
            left, right = self._composers()
        else:
            left = ImageComposer(self.rig.left, None, fill=128.0)
            right = ImageComposer(self.rig.right, self._right_from_left, fill=128.0)
        return self._plate_pair(left, right, pose, rng, noise, conditions)

    def _plate_pair(self, left, right, pose, rng, noise, conditions) -> tuple[np.ndarray, np.ndarray]:
        conditions = conditions or ImagingConditions()
        for c in (left, right):
            c.draw_plate(self.marker_texture, pose)
            draw_occluder(c, self.marker, pose, conditions)
        return self._finish(left, right, rng, noise, conditions.light)

    # -- training image -----------------------------------------------------------------
    def training_camera(self) -> tuple[CameraModel, np.ndarray]:
        """The ideal (distortion-free) camera of the training image and the marker plate pose
        in it: frontal, reference point on the image centre."""
        c = (TRAINING_SIZE - 1) / 2.0
        cam = CameraModel(np.array([[TRAINING_FOCAL, 0, c], [0, TRAINING_FOCAL, c], [0, 0, 1.0]]), np.zeros(5),
                          TRAINING_SIZE, TRAINING_SIZE)
        pose = tf.make_transform(np.diag([1.0, -1.0, -1.0]), [0.0, 0.0, TRAINING_DISTANCE])
        return cam, pose

    def training_geometry(self) -> dict:
        """Where the marker is in the training image: size, px per mm, reference point and
        outer-square corners (px, pixel-centre convention, order as in the description)."""
        cam, pose = self.training_camera()
        corners = cam.project(tf.transform_points(pose, self.marker.outer_corners()))
        ref = cam.project(tf.transform_points(pose, np.zeros((1, 3))))[0]
        return {"image_width": cam.width, "image_height": cam.height,
                "px_per_mm": TRAINING_FOCAL / TRAINING_DISTANCE,
                "reference_px": [float(v) for v in ref],
                "outer_corners_px": [[float(v) for v in p] for p in corners]}

    def render_training_image(self, rng=None, *, noise: float | None = None) -> np.ndarray:
        """A flat frontal image of the marker plate (480x480 px, 5 px/mm, reference point at
        the image centre) on a plain grey table top, with blur, mild uneven light and noise."""
        rng = _rng(rng if rng is not None else np.random.SeedSequence([int(self.seed), 7]))
        cam, pose = self.training_camera()
        c = ImageComposer(cam, None, fill=120.0)
        c.draw_plate(self.marker_texture, pose)
        noise = self.noise if noise is None else float(noise)
        return c.finish(rng, noise, vignetting_strength=0.08, gradient=float(rng.uniform(0.0, 0.08)),
                        gradient_angle=float(rng.uniform(0.0, 2 * np.pi)))


def lab_options(lab: "VirtualLab") -> dict:
    """Keyword arguments of `core.poses.selection.select_poses` for this lab: its placed nominal
    robot (base in the left camera frame), its stereo rig and marker plate, the table as the
    floor, and the marker depth range of its pose images (400–900 mm)."""
    robot = lab.nominal_robot
    return {"robot": robot, "rig": lab.rig, "plate_size": lab.plate_size, "target": lab.target,
            "floor": table_level(robot),
            "visibility": VisibilityOptions(min_depth=POSE_DEPTH[0], max_depth=POSE_DEPTH[1])}
