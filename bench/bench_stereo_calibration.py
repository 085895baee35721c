"""Stereo calibration: real pairs against plain OpenCV, virtual-lab ground truth, speed.

Real data (`../shared/data/stereo-checkerboard-640x512`, 25 pairs, 9x6, 24 mm): RoboCal's
detections and default model (k1 k2 p1 p2 k3, intrinsics refined in the stereo fit, no
pair excluded). The baseline is a plain `cv2.stereoCalibrate` on exactly the same corners,
computed in the same run, in its two usual forms: from scratch (flags 0) and after
`cv2.calibrateCamera` per camera (its default CALIB_FIX_INTRINSIC); the lower RMS is the
baseline. Focal lengths are compared with the README's reference fx = fy = 518.05 px
(the original author's rational-model, fixed-aspect run).

Virtual lab: 20 pairs rendered at 1280x1024 with the lab's default noise, seed 0, detected
and calibrated exactly as the CLI does; errors against the lab's true rig. Rotation error =
angle of R_est · R_trueᵀ.

Speed (wall clock on this machine, other processes included): detection of one 1280x1024
pair (median over the 20 lab pairs, read from memory), and the whole CLI path for 20 pairs
at 1280x1024: PNG files -> detection -> calibration (with cross-validation) -> stereo.yaml.
"""
from __future__ import annotations

import math
import statistics
import tempfile
import time
from pathlib import Path

import cv2
import numpy as np

from core.stereo.board import Board
from core.stereo.checkerboard import detect_folders, detect_pair, detect_pairs
from core.stereo.calibration import calibrate_stereo
from core.stereo.fit import CalibrationOptions
from core.stereo.file import read_stereo_yaml, write_stereo_yaml

PROJECT_ROOT = Path(__file__).resolve().parents[1]
REAL_DATA = PROJECT_ROOT.parent / "shared" / "data" / "stereo-checkerboard-640x512"
REFERENCE_FOCAL = 518.05
LAB_PAIRS = 20
LAB_SEED = 0


def run(report) -> None:
    _real(report)
    pairs, truth, board = _lab_pairs(report)
    _ground_truth(report, pairs, truth, board)
    _speed(report, pairs, board)


# --------------------------------------------------------------------------- real pairs


def _real(report) -> None:
    if not REAL_DATA.is_dir():
        report.info(f"real pairs not found at {REAL_DATA}: skipped", "")
        return
    board = Board(9, 6, 24.0)
    files = [(REAL_DATA / f"left{n:02d}.jpg", REAL_DATA / f"right{n:02d}.jpg") for n in range(1, 26)]
    det = detect_pairs(files, board)
    result = calibrate_stereo(det, CalibrationOptions())
    obj = [result.object_points.astype(np.float32)] * result.pairs_used
    left = [p.astype(np.float32) for p in result.left_points]
    right = [p.astype(np.float32) for p in result.right_points]
    size = result.file.image_size
    scratch = cv2.stereoCalibrate(obj, left, right, None, None, None, None, size, flags=0)[0]
    _, K1, D1, _, _ = cv2.calibrateCamera(obj, left, size, None, None)
    _, K2, D2, _, _ = cv2.calibrateCamera(obj, right, size, None, None)
    fixed = cv2.stereoCalibrate(obj, left, right, K1, D1, K2, D2, size)[0]
    baseline = min(scratch, fixed)
    report.info("real: pairs used / rejected", f"{result.pairs_used} / {len(result.rejected)}")
    report.info("real: plain cv2.stereoCalibrate RMS, flags 0 / after calibrateCamera",
                f"{scratch:.4f} / {fixed:.4f}", "px")
    report.add("real: RoboCal stereo RMS (<= plain OpenCV + 1e-6 px)", result.file.rms_stereo, "<=",
               baseline + 1e-6, "px", note=f"baseline {baseline:.6f} px")
    for name, value in (("left fx", result.file.K1[0, 0]), ("left fy", result.file.K1[1, 1]),
                        ("right fx", result.file.K2[0, 0]), ("right fy", result.file.K2[1, 1])):
        report.add(f"real: {name} {value:.2f} px vs 518.05 (|error|)", abs(value / REFERENCE_FOCAL - 1) * 100,
                   "<", 1.0, "%")
    report.info("real: epipolar error after rectification, RMS / max",
                f"{result.epipolar_rms:.3f} / {result.epipolar_max:.3f}", "px")
    cv = result.cross_validation
    report.info("real: cross-validation, observed area RMS / whole image max",
                f"{cv.rms_observed_px:.3f} / {cv.max_px:.2f}", "px")
    report.info("real: baseline ± std", f"{result.baseline_mm:.2f} ± {result.std['baseline']:.2f}", "mm")


# --------------------------------------------------------------------------- virtual lab


def _lab_pairs(report):
    """20 rendered pairs (left, right uint8), the true rig, the board."""
    try:
        from core.virtual_lab.lab import VirtualLab
    except ImportError as exc:          # the lab is another module; keep the speed figures
        report.info(f"virtual lab not importable ({exc}); synthetic warped boards used for speed", "")
        return _warped_pairs(), None, Board(9, 6, 25.0)
    start = time.perf_counter()
    lab = VirtualLab.create(seed=LAB_SEED)
    rng = np.random.default_rng(1000 + LAB_SEED)
    poses = lab.random_board_poses(LAB_PAIRS, rng)
    pairs = [lab.render_checkerboard_pair(p, rng) for p in poses]
    report.info(f"lab: rendered {LAB_PAIRS} pairs {pairs[0][0].shape[1]}x{pairs[0][0].shape[0]} "
                f"(noise {lab.noise} grey levels)", time.perf_counter() - start, "s")
    return pairs, lab.rig, lab.board


def _ground_truth(report, pairs, truth, board) -> None:
    if truth is None:
        report.info("lab: ground-truth figures not measured (no virtual lab)", "")
        return
    det = detect_pairs(pairs, board)
    result = calibrate_stereo(det, CalibrationOptions())
    report.info("lab: pairs used / rejected", f"{result.pairs_used} / {len(result.rejected)}")
    f_err = max(abs(result.file.K1[0, 0] / truth.left.fx - 1), abs(result.file.K1[1, 1] / truth.left.fy - 1),
                abs(result.file.K2[0, 0] / truth.right.fx - 1), abs(result.file.K2[1, 1] / truth.right.fy - 1)) * 100
    pp_err = max(abs(result.file.K1[0, 2] - truth.left.cx), abs(result.file.K1[1, 2] - truth.left.cy),
                 abs(result.file.K2[0, 2] - truth.right.cx), abs(result.file.K2[1, 2] - truth.right.cy))
    b_err = abs(result.baseline_mm / truth.baseline - 1) * 100
    dR = result.file.R @ truth.R.T
    rot = math.degrees(math.acos(min(1.0, max(-1.0, (np.trace(dR) - 1) / 2))))
    report.add("lab: focal length error (worst of fx, fy, both cameras)", f_err, "<", 0.1, "%")
    report.add("lab: principal point error (worst coordinate)", pp_err, "<", 1.0, "px")
    z = max(abs(result.file.K1[0, 2] - truth.left.cx) / result.std["cx_left"],
            abs(result.file.K1[1, 2] - truth.left.cy) / result.std["cy_left"],
            abs(result.file.K2[0, 2] - truth.right.cx) / result.std["cx_right"],
            abs(result.file.K2[1, 2] - truth.right.cy) / result.std["cy_right"])
    report.info("lab: principal point, worst |error| / reported std", z, "sigma")
    report.add("lab: baseline length error", b_err, "<", 0.1, "%")
    report.add("lab: rotation error", rot, "<", 0.05, "deg")
    report.info("lab: stereo RMS / epipolar RMS",
                f"{result.file.rms_stereo:.4f} / {result.epipolar_rms:.4f}", "px")
    report.info("lab: cross-validation, observed area RMS", result.cross_validation.rms_observed_px, "px")
    report.info("lab: baseline std (reported) / actual error",
                f"{result.std['baseline']:.4f} / {abs(result.baseline_mm - truth.baseline):.4f}", "mm")


# --------------------------------------------------------------------------- speed


def _speed(report, pairs, board) -> None:
    times = []
    for left, right in pairs:
        start = time.perf_counter()
        detect_pair(left, right, board)
        times.append((time.perf_counter() - start) * 1000)
    report.add("speed: detection of one 1280x1024 pair (median of 20)", statistics.median(times), "<=", 150,
               "ms", note=f"max {max(times):.0f} ms")
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        (tmp / "left").mkdir()
        (tmp / "right").mkdir()
        for i, (left, right) in enumerate(pairs):
            cv2.imwrite(str(tmp / "left" / f"pair_{i:03d}.png"), left)
            cv2.imwrite(str(tmp / "right" / f"pair_{i:03d}.png"), right)
        start = time.perf_counter()
        det = detect_folders(tmp / "left", tmp / "right", board)
        mid = time.perf_counter()
        result = calibrate_stereo(det, CalibrationOptions())
        write_stereo_yaml(tmp / "stereo.yaml", result)
        end = time.perf_counter()
        read_stereo_yaml(tmp / "stereo.yaml")
    report.add(f"speed: {len(pairs)} pairs 1280x1024 files -> stereo.yaml", end - start, "<", 10.0, "s",
               note=f"detection {mid - start:.2f} s, calibration + file {end - mid:.2f} s")


def _warped_pairs(n: int = LAB_PAIRS, board: Board = Board(9, 6, 25.0)):
    """Fallback images: a checkerboard texture warped into two 1280x1024 views."""
    K = np.array([[1500.0, 0, 639.5], [0, 1500.0, 511.5], [0, 0, 1]])
    px = 40
    nx, ny = board.cols + 1, board.rows + 1
    tex = np.full(((ny + 2) * px, (nx + 2) * px), 220, np.uint8)
    for j in range(ny):
        for i in range(nx):
            if (i + j) % 2 == 0:
                tex[px + j * px:px + (j + 1) * px, px + i * px:px + (i + 1) * px] = 20
    s = board.square / px
    S = np.array([[s, 0, -(2 * px - 0.5) * s], [0, s, -(2 * px - 0.5) * s], [0, 0, 1]])
    rng = np.random.default_rng(0)
    out = []
    while len(out) < n:
        R = cv2.Rodrigues(rng.normal(0, 0.3, 3))[0]
        t = np.array([rng.uniform(-200, 80), rng.uniform(-180, 60), rng.uniform(700, 1100)])
        views = []
        for shift in (0.0, -130.0):
            H = K @ np.column_stack([R[:, 0], R[:, 1], t + [shift, 0, 0]]) @ S
            img = cv2.warpPerspective(tex, H, (1280, 1024), borderValue=90).astype(np.float32)
            img = cv2.GaussianBlur(img, (0, 0), 0.8) + rng.normal(0, 1.0, (1024, 1280))
            views.append(np.clip(img, 0, 255).astype(np.uint8))
        out.append(tuple(views))
    return out
