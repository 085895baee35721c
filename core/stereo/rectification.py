"""The rectification of a calibrated stereo pair (cv2.stereoRectify: R1, R2, P1, P2, Q).

After rectification the image of a point lies on the same row of both images (the same
column for a vertical rig). `StereoRectification` maps between raw and rectified pixels
(whole images for display, strips and single positions for the correspondence search), and
`epipolar_errors` measures how well matched corners agree with it (|y_left − y_right| of the
undistorted, rectified corners, px, as ROS shows it).

`load_rectification(path)` is the one way from a stereo calibration file (RoboCal's
stereo.yaml or another tool's, core.stereo.importers) to the rectification the marker
location uses: the command line and the pages call it.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import cv2
import numpy as np

from core.camera import CameraModel, PixelMap
from core.errors import RoboCalError
from core.images import load_gray
from core.stereo.file import StereoFile
from core.stereo.rig import StereoRig

UNDISTORT_CRITERIA = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 100, 1e-12)


@dataclass(eq=False)
class StereoRectification:
    """A stereo rig with its rectification.

    `calibration` is the stereo calibration it comes from (None for a bare rig); its D1, D2
    are used for the whole-image maps, so that the rational model's k4..k6 count there.
    `require_side_by_side` refuses a rig the row-wise correspondence search cannot use (the
    cameras one above the other, or the 'right' camera on the left); a calibration result
    shows any rig."""

    rig: StereoRig
    R1: np.ndarray
    R2: np.ndarray
    P1: np.ndarray
    P2: np.ndarray
    Q: np.ndarray | None = None
    calibration: StereoFile | None = None
    require_side_by_side: bool = True
    _maps: dict = field(default_factory=dict, init=False, repr=False)

    def __post_init__(self):
        for name in ("R1", "R2"):
            setattr(self, name, np.asarray(getattr(self, name), dtype=float).reshape(3, 3))
        for name in ("P1", "P2"):
            setattr(self, name, np.asarray(getattr(self, name), dtype=float).reshape(3, 4))
        if self.require_side_by_side:
            if self.vertical:
                raise RoboCalError("the cameras are one above the other (vertical stereo); the correspondence "
                                   "search works along rows and needs them side by side",
                                   hint="Mount the cameras side by side, or calibrate with the left camera on "
                                        "the left.")
            if self.P2[0, 3] >= 0:
                raise RoboCalError("the 'right' camera is on the left of the 'left' camera (T_x > 0)",
                                   hint="Swap the left and right images (and calibrate again).")
        self.left_map = PixelMap(self.rig.left, self.R1, self.P1)
        self.right_map = PixelMap(self.rig.right, self.R2, self.P2)

    @classmethod
    def from_rig(cls, rig: StereoRig, alpha: float = 0.0) -> "StereoRectification":
        """cv2.stereoRectify(flags=CALIB_ZERO_DISPARITY, alpha) of the rig."""
        R1, R2, P1, P2, Q, _, _ = cv2.stereoRectify(rig.left.K, rig.left.dist, rig.right.K, rig.right.dist,
                                                    rig.left.size, rig.R, rig.T.reshape(3, 1),
                                                    flags=cv2.CALIB_ZERO_DISPARITY, alpha=alpha)
        return cls(rig, R1, R2, P1, P2, Q)

    @classmethod
    def from_calibration(cls, stereo: StereoFile, *, for_location: bool = True) -> "StereoRectification":
        """The rectification a calibration holds. `for_location`: refuse what the marker
        location cannot use (a vertical or swapped rig)."""
        return cls(stereo.rig, stereo.R1, stereo.R2, stereo.P1, stereo.P2, stereo.Q, calibration=stereo,
                   require_side_by_side=for_location)

    @property
    def image_size(self) -> tuple[int, int]:
        return self.rig.left.size

    @property
    def vertical(self) -> bool:
        """True when the cameras are one above the other (rectified columns are epipolar lines)."""
        return bool(abs(self.P2[1, 3]) > abs(self.P2[0, 3]))

    @property
    def focal(self) -> float:
        return float(self.P1[0, 0])

    @property
    def baseline(self) -> float:
        return -float(self.P2[0, 3]) / float(self.P2[0, 0])

    @property
    def disparity_offset(self) -> float:
        """cx_left − cx_right of the rectified cameras (0 with CALIB_ZERO_DISPARITY)."""
        return float(self.P1[0, 2] - self.P2[0, 2])

    def disparity_of_depth(self, z: float) -> float:
        return self.focal * self.baseline / z + self.disparity_offset

    def distortion(self, side: str) -> np.ndarray:
        """The distortion coefficients of one camera (5, or 8 for the rational model)."""
        if self.calibration is not None:
            return self.calibration.D1 if side == "left" else self.calibration.D2
        return (self.rig.left if side == "left" else self.rig.right).dist

    def pixel_map(self, side: str) -> PixelMap:
        return self.left_map if side == "left" else self.right_map

    # -- whole images (display) ------------------------------------------------------------------

    def maps(self, m1type: int = cv2.CV_16SC2):
        """Rectification maps ((map1x, map1y), (map2x, map2y)) for cv2.remap, computed once."""
        if m1type not in self._maps:
            left = cv2.initUndistortRectifyMap(self.rig.left.K, self.distortion("left"), self.R1, self.P1,
                                               self.image_size, m1type)
            right = cv2.initUndistortRectifyMap(self.rig.right.K, self.distortion("right"), self.R2, self.P2,
                                                self.image_size, m1type)
            self._maps[m1type] = (left, right)
        return self._maps[m1type]

    def rectify(self, left: np.ndarray, right: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The rectified pair (a preview: rows of the two images are epipolar lines)."""
        (l1, l2), (r1, r2) = self.maps()
        return (cv2.remap(left, l1, l2, cv2.INTER_LINEAR), cv2.remap(right, r1, r2, cv2.INTER_LINEAR))

    def rectify_files(self, left_path, right_path) -> tuple[np.ndarray, np.ndarray]:
        """Read a pair of image files and rectify it (RoboCalError naming an unreadable file)."""
        images = []
        for path in (left_path, right_path):
            image, why = load_gray(path)
            if image is None:
                raise RoboCalError(f"cannot show this pair: {why}", source=path)
            images.append(image)
        return self.rectify(*images)

    # -- strips and positions (the correspondence search) ------------------------------------------

    def raw_positions(self, side: str, xs: np.ndarray, ys: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Raw pixel positions (map_x, map_y) float32 (len(ys), len(xs)) of the rectified grid."""
        X, Y = np.meshgrid(np.asarray(xs, float), np.asarray(ys, float))
        return self.raw_of(side, X, Y)

    def raw_of(self, side: str, X: np.ndarray, Y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Raw pixel positions (float32 arrays shaped like X) of rectified positions (X, Y)."""
        cam: CameraModel = self.rig.left if side == "left" else self.rig.right
        R = self.R1 if side == "left" else self.R2
        P = (self.P1 if side == "left" else self.P2)[:3, :3]
        h = np.stack([X, Y, np.ones_like(X)], axis=-1) @ np.linalg.inv(P).T
        ray = h @ R            # back to the camera frame (R^T for row vectors)
        xy = ray[..., :2] / ray[..., 2:3]
        uv = cam.normalized_to_pixels(xy)
        return uv[..., 0].astype(np.float32), uv[..., 1].astype(np.float32)

    def rectify_strip(self, image: np.ndarray, side: str, xs: np.ndarray, ys: np.ndarray) -> np.ndarray:
        """The rectified image sampled at the grid xs × ys (float32, bilinear; NaN outside)."""
        mx, my = self.raw_positions(side, xs, ys)
        return remap_region(image, mx, my)

    def sample(self, image: np.ndarray, side: str, X: np.ndarray, Y: np.ndarray) -> np.ndarray:
        """The rectified image at arbitrary rectified positions (X, Y) (float32, bilinear, NaN outside)."""
        mx, my = self.raw_of(side, np.asarray(X, float), np.asarray(Y, float))
        return remap_region(image, mx, my)


def remap_region(image: np.ndarray, mx: np.ndarray, my: np.ndarray) -> np.ndarray:
    """cv2.remap (bilinear, float32, NaN outside the image) converting only the region used."""
    img = image if image.ndim == 2 else cv2.cvtColor(image, cv2.COLOR_BGR2GRAY)
    H, W = img.shape
    fin = np.isfinite(mx) & np.isfinite(my)
    if not fin.any():
        return np.full(mx.shape, np.nan, np.float32)
    x0 = int(np.clip(np.floor(mx[fin].min()) - 2, 0, W - 1))
    x1 = int(np.clip(np.ceil(mx[fin].max()) + 3, x0 + 1, W))
    y0 = int(np.clip(np.floor(my[fin].min()) - 2, 0, H - 1))
    y1 = int(np.clip(np.ceil(my[fin].max()) + 3, y0 + 1, H))
    sub = img[y0:y1, x0:x1].astype(np.float32)
    out = cv2.remap(sub, (mx - x0).astype(np.float32), (my - y0).astype(np.float32), cv2.INTER_LINEAR,
                    borderMode=cv2.BORDER_CONSTANT, borderValue=np.nan)
    # pixels whose 2x2 neighbourhood leaves the image are unknown
    outside = ~fin | (mx < -0.5) | (my < -0.5) | (mx > W - 0.5) | (my > H - 0.5)
    out[outside] = np.nan
    return out


def load_rectification(path: str | Path) -> StereoRectification:
    """The rectification of a stereo calibration file (any format core.stereo.importers reads,
    or a folder holding one), checked for the marker location (RoboCalError naming the file
    and the field of any problem)."""
    from core.stereo.importers import read_any_stereo

    imported = read_any_stereo(path)
    try:
        return StereoRectification.from_calibration(imported.file)
    except RoboCalError as exc:
        if exc.source is not None:
            raise
        raise RoboCalError(exc.problem, source=path, field=exc.field, hint=exc.hint) from None


@dataclass
class EpipolarErrors:
    """The epipolar error of matched corners after rectification."""

    errors: np.ndarray            # (V, N) signed y_left − y_right (x for vertical), px
    rms: float
    max: float
    rectified_left: np.ndarray    # (V, N, 2) rectified corner positions (for drawing)
    rectified_right: np.ndarray


def epipolar_errors(rect: StereoRectification, left_points: np.ndarray, right_points: np.ndarray
                    ) -> EpipolarErrors:
    """Rectify matched corners (V, N, 2) px of both images and compare their rows (columns
    for a vertical rig)."""
    V, N = left_points.shape[:2]
    rl = cv2.undistortPoints(left_points.reshape(-1, 1, 2), rect.rig.left.K, rect.distortion("left"),
                             R=rect.R1, P=rect.P1, criteria=UNDISTORT_CRITERIA).reshape(V, N, 2)
    rr = cv2.undistortPoints(right_points.reshape(-1, 1, 2), rect.rig.right.K, rect.distortion("right"),
                             R=rect.R2, P=rect.P2, criteria=UNDISTORT_CRITERIA).reshape(V, N, 2)
    axis = 0 if rect.vertical else 1
    err = rl[..., axis] - rr[..., axis]
    return EpipolarErrors(err, float(np.sqrt(np.mean(err ** 2))), float(np.max(np.abs(err))), rl, rr)
