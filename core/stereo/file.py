"""The stereo calibration file `stereo.yaml` and its exports (ROS camera_info, JSON).

`stereo.yaml` is OpenCV FileStorage YAML, readable by `cv2.FileStorage` in Python and C++:

    format: "robocal.stereo/1"
    image_width, image_height            int, px
    K1, D1, K2, D2                       intrinsics (3x3) and distortion (1x5 or 1x8, OpenCV order)
    R, T                                 X_right = R·X_left + T; T (3x1) in mm
    E, F                                 essential and fundamental matrices (3x3)
    R1, R2, P1, P2, Q                    cv2.stereoRectify output (3x3, 3x4, 3x4, 4x4; mm)
    rectify_alpha                        cv2.stereoRectify's free scaling, 0..1 (absent: 0)
    rms_left, rms_right, rms_stereo      px (absent: unknown, e.g. a calibration imported from another tool)
    board_cols, board_rows, board_square inner corners and square size (mm) (absent: unknown)
    epipolar_rms, cross_validation_px    optional, px

Writing is atomic: FileStorage composes the YAML in memory and core.files writes it through a
temporary file and a rename; a failed run never leaves half a file and never overwrites a
previous good one. Reading names the file and the field of any problem, refuses unknown major
versions and checks the calibration (core.stereo.checks). Calibrations written by other tools
are read by core.stereo.importers.

ROS export (`write_ros_camera_info`): one camera_info YAML per camera in the format of
camera_calibration_parsers (image_width, image_height, camera_name, camera_matrix,
distortion_model plumb_bob or rational_polynomial, distortion_coefficients,
rectification_matrix, projection_matrix). ROS works in metres: the projection matrix'
translation column (P2[0,3] = −f'·B) is converted from mm to m. Every matrix entry is written
as a YAML float (`0.0`, `1.0e-05`), as ROS's calibrator writes them.
"""
from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path

import cv2
import numpy as np

from core.stereo.board import Board
from core.camera import CameraModel
from core.stereo.checks import check_stereo
from core.errors import RoboCalError
from core.files import (atomic_write_json, atomic_write_many, atomic_write_text, ensure_writable_dir, json_default,
                        json_text, strict_json)
from core.stereo.rig import StereoRig
from core.validate import check_format

# The parameters a triangulated point depends on most, in the order of the file's
# "parameter_covariance" (core/stereo/uncertainty.py computes it):
TRIANGULATION_PARAMETERS = (tuple(f"{n}_{side}" for side in ("left", "right") for n in ("fx", "fy", "cx", "cy"))
                            + ("rx", "ry", "rz", "tx", "ty", "tz"))     # px, px, px, px (×2), deg (×3), mm (×3)

FAMILY = "robocal.stereo"
MAJOR = 1
FORMAT = f"{FAMILY}/{MAJOR}"

_MATRICES = {"K1": (3, 3), "K2": (3, 3), "R": (3, 3), "T": (3, 1), "E": (3, 3), "F": (3, 3),
             "R1": (3, 3), "R2": (3, 3), "P1": (3, 4), "P2": (3, 4), "Q": (4, 4)}
DIST_LENGTHS = (4, 5, 8, 12, 14)


@dataclass
class StereoFile:
    """A calibrated stereo pair as stereo.yaml holds it: the one home of K1, D1, K2, D2, R, T,
    E, F and the rectification matrices (a calibration result holds one)."""

    image_size: tuple[int, int]
    K1: np.ndarray
    D1: np.ndarray
    K2: np.ndarray
    D2: np.ndarray
    R: np.ndarray
    T: np.ndarray             # (3,) mm
    E: np.ndarray
    F: np.ndarray
    R1: np.ndarray
    R2: np.ndarray
    P1: np.ndarray
    P2: np.ndarray
    Q: np.ndarray
    rms_left: float | None = None       # px; None: unknown (imported from another tool)
    rms_right: float | None = None
    rms_stereo: float | None = None
    board: Board | None = None          # None: unknown
    extras: dict = field(default_factory=dict)    # epipolar_rms, cross_validation_px (optional)
    rectify_alpha: float = 0.0    # stereoRectify alpha: 0 only valid pixels, 1 every source pixel

    @property
    def rig(self) -> StereoRig:
        """The calibrated pair (5 distortion coefficients, or 8 with the rational model)."""
        w, h = self.image_size
        return StereoRig(CameraModel(self.K1, self.D1, w, h), CameraModel(self.K2, self.D2, w, h),
                         self.R, self.T)

    @property
    def baseline_mm(self) -> float:
        return float(np.linalg.norm(self.T))

    def to_dict(self) -> dict:
        """Plain lists and numbers (the JSON export)."""
        d = {"format": FORMAT, "image_width": self.image_size[0], "image_height": self.image_size[1]}
        for key in ("K1", "D1", "K2", "D2", "R", "T", "E", "F", "R1", "R2", "P1", "P2", "Q"):
            d[key] = np.asarray(getattr(self, key), dtype=float).tolist()
        d["rectify_alpha"] = float(self.rectify_alpha)
        board = self.board
        d.update(rms_left=self.rms_left, rms_right=self.rms_right, rms_stereo=self.rms_stereo,
                 board_cols=board.cols if board else None, board_rows=board.rows if board else None,
                 board_square=board.square if board else None,
                 baseline_mm=self.baseline_mm, units={"length": "mm", "image": "px"})
        d.update({k: float(v) for k, v in self.extras.items()})
        return d


def _as_file(data) -> StereoFile:
    """A StereoFile, or the file of a core.stereo.calibration.StereoCalibrationResult."""
    return data if isinstance(data, StereoFile) else data.file


# --------------------------------------------------------------------------- stereo.yaml


def write_stereo_yaml(path: str | Path, data) -> Path:
    """Write stereo.yaml (from a StereoFile or a StereoCalibrationResult), atomically."""
    return atomic_write_text(path, stereo_yaml_text(data))


def stereo_yaml_text(data) -> str:
    """The text of stereo.yaml, composed in memory by cv2.FileStorage."""
    sf = _as_file(data)
    fs = cv2.FileStorage("stereo.yaml", cv2.FILE_STORAGE_WRITE | cv2.FILE_STORAGE_MEMORY
                         | cv2.FILE_STORAGE_FORMAT_YAML)
    fs.write("format", FORMAT)
    fs.write("image_width", int(sf.image_size[0]))
    fs.write("image_height", int(sf.image_size[1]))
    for key in ("K1", "D1", "K2", "D2", "R", "T", "E", "F", "R1", "R2", "P1", "P2", "Q"):
        value = np.asarray(getattr(sf, key), dtype=np.float64)
        if key in ("D1", "D2"):
            value = value.reshape(1, -1)
        elif key == "T":
            value = value.reshape(3, 1)
        fs.write(key, value)
    fs.write("rectify_alpha", float(sf.rectify_alpha))
    for key in ("rms_left", "rms_right", "rms_stereo"):
        if getattr(sf, key) is not None:           # unknown statistics are left out, never written as 0
            fs.write(key, float(getattr(sf, key)))
    if sf.board is not None:
        fs.write("board_cols", int(sf.board.cols))
        fs.write("board_rows", int(sf.board.rows))
        fs.write("board_square", float(sf.board.square))
    for key, value in sf.extras.items():
        fs.write(key, float(value))
    return fs.releaseAndGetString()


BOM = b"\xef\xbb\xbf"                 # UTF-8 byte-order mark some editors write first


def open_storage(path, mode):
    """cv2.FileStorage, or None when it cannot be opened (OpenCV's own log line silenced); a
    file read that starts with a byte-order mark is read without it."""
    logging = getattr(getattr(cv2, "utils", None), "logging", None)
    old = None
    if logging is not None:
        old = logging.getLogLevel()
        logging.setLogLevel(logging.LOG_LEVEL_SILENT)
    try:
        head = Path(path).read_bytes()[:3] if mode == cv2.FILE_STORAGE_READ else b""
    except OSError:
        head = b""
    try:
        if head == BOM:                   # OpenCV cannot read past a byte-order mark: read the text after it
            text = Path(path).read_bytes()[len(BOM):].decode("utf-8", errors="replace")
            fs = cv2.FileStorage(text, mode | cv2.FILE_STORAGE_MEMORY)
        else:
            fs = cv2.FileStorage(str(path), mode)
    except (cv2.error, SystemError):      # SystemError: OpenCV's parse error under `-W error`
        return None
    finally:
        if logging is not None:
            logging.setLogLevel(old)
    return fs if fs.isOpened() else None


def read_stereo_yaml(path: str | Path) -> StereoFile:
    """Read stereo.yaml with a clear message for any missing or malformed field."""
    path = Path(path)
    if not path.exists():
        raise RoboCalError("file not found", source=path, hint="Run the stereo calibration first.")
    if not path.is_file():
        raise RoboCalError("not a file", source=path)
    try:
        head = path.read_bytes()[:64]
    except OSError as exc:
        raise RoboCalError(f"cannot read the file ({exc.strerror})", source=path) from exc
    if b"\x00" in head:
        raise RoboCalError("not a YAML file", source=path, hint="Give the stereo.yaml written by RoboCal.")
    fs = open_storage(path, cv2.FILE_STORAGE_READ)
    if fs is None:
        raise RoboCalError("not a readable OpenCV YAML file", source=path,
                           hint="Give the stereo.yaml written by RoboCal, or write it again.")
    try:
        root = fs.root()
        if not root.isMap():
            raise RoboCalError("expected a map of named fields at the top level", source=path)
        fmt = fs.getNode("format")
        tag = fmt.string() if (not fmt.empty() and fmt.isString()) else (None if fmt.empty() else repr(fmt.real()))
        check_format({} if tag is None else {"format": tag}, FAMILY, MAJOR, path)
        w = node_int(fs, "image_width", path)
        h = node_int(fs, "image_height", path)
        mats = {key: _matrix(fs, key, shape, path) for key, shape in _MATRICES.items()}
        alpha = 0.0 if fs.getNode("rectify_alpha").empty() else node_real(fs, "rectify_alpha", path)
        d1 = _dist(fs, "D1", path)
        d2 = _dist(fs, "D2", path)
        rms = {key: None if fs.getNode(key).empty() else node_real(fs, key, path)
               for key in ("rms_left", "rms_right", "rms_stereo")}
        board_keys = ("board_cols", "board_rows", "board_square")
        has_board = any(not fs.getNode(key).empty() for key in board_keys)
        if has_board:
            cols = node_int(fs, "board_cols", path)
            rows = node_int(fs, "board_rows", path)
            square = node_real(fs, "board_square", path)
        extras = {}
        for key in ("epipolar_rms", "cross_validation_px"):
            node = fs.getNode(key)
            if not node.empty() and (node.isReal() or node.isInt()):
                extras[key] = float(node.real())
    except cv2.error as exc:
        raise RoboCalError(f"malformed OpenCV YAML ({str(exc).strip().splitlines()[-1]})", source=path) from exc
    finally:
        fs.release()
    if not 0.0 <= alpha <= 1.0:
        raise RoboCalError(f"expected a value from 0 to 1, got {alpha}", source=path, field="rectify_alpha")
    if w <= 0 or h <= 0:
        raise RoboCalError(f"image size must be positive, got {w}x{h}", source=path, field="image_width")
    board = None
    if has_board:
        if cols < 2 or rows < 2 or not square > 0:
            raise RoboCalError(f"bad board definition {cols}x{rows}, {square} mm", source=path, field="board_cols")
        board = Board(cols, rows, square)
    for key, value in rms.items():
        if value is not None and value < 0:
            raise RoboCalError(f"an RMS error cannot be negative, got {value}", source=path, field=key)
    sf = StereoFile((w, h), mats["K1"], d1, mats["K2"], d2, mats["R"], mats["T"].reshape(3), mats["E"], mats["F"],
                    mats["R1"], mats["R2"], mats["P1"], mats["P2"], mats["Q"],
                    rms["rms_left"], rms["rms_right"], rms["rms_stereo"], board, extras, alpha)
    check_stereo(sf, path)
    return sf


def _node(fs, key, path):
    node = fs.getNode(key)
    if node.empty():
        raise RoboCalError("missing", source=path, field=key,
                           hint="Write the file again with `robocal stereo-calibrate`.")
    return node


def node_int(fs, key, path) -> int:
    node = _node(fs, key, path)
    if not node.isInt():
        raise RoboCalError("expected a whole number", source=path, field=key)
    return int(node.real())


def node_real(fs, key, path) -> float:
    node = _node(fs, key, path)
    if not (node.isReal() or node.isInt()):
        raise RoboCalError("expected a number", source=path, field=key)
    value = float(node.real())
    if not np.isfinite(value):
        raise RoboCalError(f"expected a finite number, got {value}", source=path, field=key)
    return value


def node_matrix(fs, key, path) -> np.ndarray:
    """A matrix (!!opencv-matrix) built from its rows, cols and data entries, checked first:
    cv2.FileNode.mat() writes past its buffer when rows·cols and data disagree."""
    node = _node(fs, key, path)
    what = "expected an OpenCV matrix (!!opencv-matrix with rows, cols, dt, data, or a list of numbers)"
    if node.isSeq():
        return _list_matrix(node, key, path, what)
    if not node.isMap():
        raise RoboCalError(what, source=path, field=key)
    rows, cols, dt, data = (node.getNode(name) for name in ("rows", "cols", "dt", "data"))
    if rows.empty() or cols.empty() or dt.empty() or data.empty() or not (rows.isInt() and cols.isInt()):
        raise RoboCalError(what, source=path, field=key)
    r, c = int(rows.real()), int(cols.real())
    if not (1 <= r <= 16 and 1 <= c <= 16):
        raise RoboCalError(f"expected a small matrix (at most 16x16), got rows {r}, cols {c}", source=path, field=key)
    if not dt.isString() or dt.string() not in ("d", "f", "i", "u", "s", "w", "c"):
        raise RoboCalError("expected a matrix of one channel (dt: d, f or i)", source=path, field=key)
    if not data.isSeq() or data.size() != r * c:
        got = data.size() if data.isSeq() else "no list of"
        raise RoboCalError(f"a {r}x{c} matrix needs {r * c} values in data, got {got}", source=path, field=key)
    values = []
    for i in range(r * c):
        item = data.at(i)
        if not (item.isReal() or item.isInt()):
            raise RoboCalError("data holds something other than numbers", source=path, field=key)
        values.append(item.real())
    m = np.array(values, dtype=np.float64).reshape(r, c)
    if not np.all(np.isfinite(m)):
        raise RoboCalError("contains values that are not finite numbers", source=path, field=key)
    return m


def _list_matrix(node, key, path, what: str) -> np.ndarray:
    """A plain list as cv2.FileStorage reads it: [a, b, c] is a column (n x 1), [[a, b], [c, d]]
    a matrix of rows."""
    def number(item) -> float:
        if not (item.isReal() or item.isInt()):
            raise RoboCalError(what, source=path, field=key)
        return item.real()

    n = node.size()
    if not 1 <= n <= 16:
        raise RoboCalError(f"expected a small matrix (1 to 16 rows), got a list of {n}", source=path, field=key)
    items = [node.at(i) for i in range(n)]
    if all(item.isSeq() for item in items):
        widths = {item.size() for item in items}
        if len(widths) != 1 or not 1 <= widths.pop() <= 16:
            raise RoboCalError("expected rows of one length (at most 16)", source=path, field=key)
        m = np.array([[number(item.at(j)) for j in range(item.size())] for item in items], dtype=np.float64)
    else:
        m = np.array([[number(item)] for item in items], dtype=np.float64)
    if not np.all(np.isfinite(m)):
        raise RoboCalError("contains values that are not finite numbers", source=path, field=key)
    return m


def _matrix(fs, key, shape, path) -> np.ndarray:
    m = node_matrix(fs, key, path)
    ok = m.shape == shape or (key == "T" and m.size == 3)
    if not ok:
        raise RoboCalError(f"expected a {shape[0]}x{shape[1]} matrix, got {m.shape[0]}x{m.shape[1]}",
                           source=path, field=key)
    return m.reshape(shape)


def _dist(fs, key, path) -> np.ndarray:
    m = node_matrix(fs, key, path)
    if min(m.shape) != 1 or m.size not in DIST_LENGTHS:
        raise RoboCalError(f"expected 4, 5, 8, 12 or 14 distortion coefficients in one row, "
                           f"got a {m.shape[0]}x{m.shape[1]} matrix", source=path, field=key)
    d = m.ravel()
    if d.size < 5:
        d = np.concatenate([d, np.zeros(5 - d.size)])
    return d


# --------------------------------------------------------------------------- exports


def camera_info_yaml(data, side: str, camera_name: str | None = None) -> str:
    """ROS camera_info YAML text of one camera ("left" or "right")."""
    sf = _as_file(data)
    if side not in ("left", "right"):
        raise ValueError(f"side must be 'left' or 'right', got {side!r}")
    K, D, Rr, P = (sf.K1, sf.D1, sf.R1, sf.P1) if side == "left" else (sf.K2, sf.D2, sf.R2, sf.P2)
    D = np.asarray(D, dtype=float).ravel()
    if D.size > 5 and np.any(D[5:8] != 0):
        model, D = "rational_polynomial", np.concatenate([D, np.zeros(max(0, 8 - D.size))])[:8]
    else:
        model, D = "plumb_bob", np.concatenate([D, np.zeros(max(0, 5 - D.size))])[:5]
    P = np.array(P, dtype=float)
    P[:, 3] /= 1000.0          # mm -> m (ROS units)
    name = camera_name or side

    def block(label, M, rows, cols):
        values = ", ".join(_num(v) for v in np.asarray(M, dtype=float).ravel())
        return f"{label}:\n  rows: {rows}\n  cols: {cols}\n  data: [{values}]\n"

    return (f"image_width: {int(sf.image_size[0])}\n"
            f"image_height: {int(sf.image_size[1])}\n"
            f"camera_name: {name}\n"
            + block("camera_matrix", K, 3, 3)
            + f"distortion_model: {model}\n"
            + block("distortion_coefficients", D, 1, D.size)
            + block("rectification_matrix", Rr, 3, 3)
            + block("projection_matrix", P, 3, 4))


def _num(v: float) -> str:
    """A YAML float that reads back exactly, always with a point: YAML 1.1 readers (pyyaml)
    take `0` for an integer and `1e-05` for text."""
    mantissa, e, exponent = repr(float(v) + 0.0).partition("e")      # + 0.0: no "-0.0"
    if "." not in mantissa:
        mantissa += ".0"
    return mantissa + e + exponent


def write_ros_camera_info(folder: str | Path, data, names: tuple[str, str] = ("left", "right")
                          ) -> tuple[Path, Path]:
    """Write left.yaml and right.yaml (ROS camera_info) into `folder`, both or neither."""
    left, right = atomic_write_many(ros_camera_info_files(ensure_writable_dir(folder), data, names))
    return left, right


def ros_camera_info_files(folder: str | Path, data, names: tuple[str, str] = ("left", "right")
                          ) -> dict[Path, str]:
    """{folder/left.yaml: text, folder/right.yaml: text} of the ROS camera_info export."""
    return {Path(folder) / f"{name}.yaml": camera_info_yaml(data, side, name)
            for side, name in zip(("left", "right"), names)}


def stereo_json(data, result=None) -> dict:
    """The JSON export: the stereo.yaml fields, plus the calibration details when `result`
    (a StereoCalibrationResult) is given: summary, parameter table with standard
    deviations, the covariance of the parameters a triangulated point depends on, the outlier
    threshold, per-view errors and every corner's residual
    (observed − projected, px)."""
    if result is None and not isinstance(data, StereoFile):
        result = data
    d = _as_file(data).to_dict()
    if result is not None:
        d["calibration"] = result.summary()
        d["parameters"] = [{"group": r.group, "name": r.name, "value": r.value, "std": r.std,
                            "unit": r.unit, "fixed": r.fixed} for r in result.parameters]
        if result.covariance is not None:
            d["parameter_covariance"] = {"names": list(TRIANGULATION_PARAMETERS), "units": "px, deg, mm",
                                         "matrix": np.asarray(result.covariance, float).tolist()}
        d["outlier_threshold_px"] = float(result.outlier_threshold)
        d["views"] = [{"pair": int(i) + 1, "files": name, "rms_left": float(result.per_view_rms_left[k]),
                       "rms_right": float(result.per_view_rms_right[k]), "rms": float(result.per_view_rms[k]),
                       "outlier": int(i) in result.outliers,
                       "residuals_left_px": np.round(result.fit.residuals_left[k], 4).tolist(),
                       "residuals_right_px": np.round(result.fit.residuals_right[k], 4).tolist()}
                      for k, (i, name) in enumerate(zip(result.view_indices, result.view_names))]
    return strict_json(json.loads(json.dumps(d, default=json_default)))


def write_stereo_json(path: str | Path, data, result=None) -> Path:
    """Write the JSON export atomically."""
    return atomic_write_json(path, stereo_json(data, result))


def stereo_json_text(data, result=None) -> str:
    """The text `write_stereo_json` writes."""
    return json_text(stereo_json(data, result))
