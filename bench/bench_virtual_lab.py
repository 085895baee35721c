"""Virtual lab: renderer corner accuracy, render time, and the speed of `robocal simulate`.

Corner targets are about 2x the RMS measured on these poses (0.037 px at zero and at the
default noise). Times are ratios to a plain renderer timed in the same run: a checkerboard
texture put in the image by cv2.warpPerspective, blurred and given Gaussian noise (no lens
distortion, lighting, background or marker plate), and for `simulate` that same image written
as a PNG (cv2.imwrite) once per image of the dataset; the absolute times are beside them.
Image memory: 12 marker pairs rendered and searched by SIFT in a fresh process with RoboCal's
allocator settings (core/__init__.py), as a ratio to the same work in a fresh process with glibc's
defaults (GLIBC_TUNABLES set, which leaves them alone); the better of two runs each.
"""
from __future__ import annotations

import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import cv2
import numpy as np

from core import transforms as tf
from core.virtual_lab.dataset import simulate_dataset
from core.virtual_lab.lab import VirtualLab

SUBPIX_CRITERIA = (cv2.TERM_CRITERIA_EPS | cv2.TERM_CRITERIA_COUNT, 30, 1e-3)
N_POSES = 10
RENDER_RATIO = 4.0         # about 2x the measured ratio (1.8)
SIMULATE_RATIO = 7.0       # about 2x the measured ratio (3.5)
MEMORY_RATIO = 0.9         # RoboCal's allocator settings: faster than glibc's defaults (measured 0.75)

# 12 marker pairs rendered and their left images searched by SIFT; prints seconds and page faults
_IMAGE_WORK = """
import resource, time
import numpy as np
from core.marker.detection import sift_features
from core.virtual_lab.lab import VirtualLab
lab = VirtualLab.create(seed=3)
lab.render_marker_pair(np.zeros(6), np.random.default_rng(0))
before, t = resource.getrusage(resource.RUSAGE_SELF).ru_minflt, time.perf_counter()
for i in range(12):
    sift_features(lab.render_marker_pair(np.full(6, 0.03 * i), np.random.default_rng(i))[0])
print(time.perf_counter() - t, resource.getrusage(resource.RUSAGE_SELF).ru_minflt - before)
"""


def _image_work(defaults: bool) -> tuple[float, int]:
    """(seconds, page faults) of _IMAGE_WORK in a fresh process, with glibc's allocator defaults
    or RoboCal's settings; the faster of two runs."""
    env = {k: v for k, v in os.environ.items() if not k.startswith("MALLOC_") and k != "GLIBC_TUNABLES"}
    if defaults:
        env["GLIBC_TUNABLES"] = ""
    root = str(Path(__file__).resolve().parents[1])
    env["PYTHONPATH"] = root + os.pathsep + env.get("PYTHONPATH", "")
    runs = []
    for _ in range(2):
        out = subprocess.run([sys.executable, "-c", _IMAGE_WORK], capture_output=True, text=True, check=True,
                             env=env, cwd=root)
        seconds, faults = out.stdout.split()
        runs.append((float(seconds), int(faults)))
    return min(runs)


def _plain_image(rng: np.random.Generator) -> np.ndarray:
    """One 1280x1024 image from the plain renderer (see the module's docstring)."""
    px = 40
    tex = np.kron((np.indices((8, 11)).sum(axis=0) % 2 * 200 + 20).astype(np.uint8), np.ones((px, px), np.uint8))
    R = cv2.Rodrigues(rng.normal(0, 0.3, 3))[0]
    K = np.array([[1500.0, 0, 639.5], [0, 1500.0, 511.5], [0, 0, 1]])
    S = np.array([[0.625, 0, -140.0], [0, 0.625, -110.0], [0, 0, 1]])
    H = K @ np.column_stack([R[:, 0], R[:, 1], [rng.uniform(-50, 50), rng.uniform(-50, 50), 900.0]]) @ S
    img = cv2.warpPerspective(tex, H, (1280, 1024), borderValue=90).astype(np.float32)
    img = cv2.GaussianBlur(img, (0, 0), 0.8) + rng.normal(0, 0.5, (1024, 1280))
    return np.clip(img, 0, 255).astype(np.uint8)

def _corner_errors(lab: VirtualLab, poses, noise: float, win) -> np.ndarray:
    """Squared corner errors (px²) of OpenCV's corners against the model's projections."""
    out = []
    for i, pose in enumerate(poses):
        images = lab.render_checkerboard_pair(pose, np.random.default_rng(100 + i), noise=noise)
        left_pts = tf.transform_points(pose, lab.board.object_points().astype(float))
        for img, cam, pts in ((images[0], lab.rig.left, left_pts), (images[1], lab.rig.right, lab.rig.to_right(left_pts))):
            ok, corners = cv2.findChessboardCorners(img, lab.board.pattern_size,
                                                    flags=cv2.CALIB_CB_ADAPTIVE_THRESH | cv2.CALIB_CB_NORMALIZE_IMAGE)
            if not ok:
                out.append(np.full(len(pts), np.inf))
                continue
            corners = cv2.cornerSubPix(img, corners, win, (-1, -1), SUBPIX_CRITERIA).reshape(-1, 2)
            proj = cam.project(pts)
            e1 = ((corners - proj) ** 2).sum(1)
            e2 = ((corners[::-1] - proj) ** 2).sum(1)
            out.append(e1 if e1.mean() <= e2.mean() else e2)
    return np.concatenate(out)


def run(report) -> None:
    t0 = time.perf_counter()
    lab = VirtualLab.create(seed=0)
    report.info("virtual lab creation (ray maps, room)", time.perf_counter() - t0, "s")
    poses = lab.random_board_poses(N_POSES, np.random.default_rng(1))

    e = _corner_errors(lab, poses, 0.0, (5, 5))
    report.add(f"corner RMS, zero noise, {N_POSES} poses x 2 cameras, win 5x5", np.sqrt(e.mean()), "<", 0.075, "px")
    report.info("  worst corner, zero noise, win 5x5", np.sqrt(e.max()), "px")
    e = _corner_errors(lab, poses, 0.0, (11, 11))
    report.info("corner RMS, zero noise, win 11x11", np.sqrt(e.mean()), "px")
    e = _corner_errors(lab, poses, lab.noise, (5, 5))
    report.add(f"corner RMS, default noise ({lab.noise} grey levels), win 5x5", np.sqrt(e.mean()), "<", 0.075, "px")

    Q = lab.random_visible_poses(5, np.random.default_rng(2))
    times = []
    for i in range(3):
        t = time.perf_counter()
        lab.render_checkerboard_pair(poses[i], np.random.default_rng(i))
        times.append((time.perf_counter() - t) / 2)
    for i, q in enumerate(Q):
        t = time.perf_counter()
        lab.render_marker_pair(q, np.random.default_rng(i))
        times.append((time.perf_counter() - t) / 2)
    plain = []
    for i in range(len(times)):
        t = time.perf_counter()
        _plain_image(np.random.default_rng(i))
        plain.append(time.perf_counter() - t)
    render, base = float(np.mean(times)), float(np.mean(plain))
    report.add("render time per 1280x1024 image (board and marker) / plain warp renderer", render / base, "<=",
               RENDER_RATIO, "x", note=f"{render:.4f} vs {base:.4f} s")

    with tempfile.TemporaryDirectory(prefix="robocal-bench-") as tmp:
        t = time.perf_counter()
        result = simulate_dataset(Path(tmp) / "ds", seed=0, pairs=20, poses=40)
        elapsed = time.perf_counter() - t
        size = sum(p.stat().st_size for p in (Path(tmp) / "ds").rglob("*") if p.is_file())
        n_images = 2 * (result.pairs + result.poses) + 1
        t = time.perf_counter()
        for i in range(n_images):
            cv2.imwrite(str(Path(tmp) / "plain.png"), _plain_image(np.random.default_rng(i)))
        plain_dataset = time.perf_counter() - t
    report.add(f"simulate default dataset ({result.pairs} pairs + {result.poses} poses + training) / plain "
               f"render + PNG of {n_images} images", elapsed / plain_dataset, "<=", SIMULATE_RATIO, "x",
               note=f"{elapsed:.2f} vs {plain_dataset:.2f} s")
    report.info("  dataset size on disk", size / 1e6, "MB")

    if sys.platform.startswith("linux"):
        kept, default = _image_work(defaults=False), _image_work(defaults=True)
        report.add("12 marker pairs rendered and searched (SIFT), freed image memory kept / glibc's defaults",
                   kept[0] / default[0], "<", MEMORY_RATIO, "x", note=f"{kept[0]:.2f} vs {default[0]:.2f} s")
        report.info("  page faults, freed image memory kept", kept[1])
        report.info("  page faults, glibc's defaults", default[1])
