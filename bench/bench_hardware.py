"""Hardware path: capture latency, the Setup page's preview rate, serial round trip over a pty,
a measurement run over sim-robot."""
from __future__ import annotations

import tempfile
import time
from pathlib import Path
from types import SimpleNamespace

import cv2
import numpy as np

from core.measurement.capture import RenderedSource, StereoSource, open_camera
from core.measurement.run import poses_from_internal, run_measurements
from core.robot.controller_sim import ControllerSim
from core.robot.serial_robot import SerialRobot
from core.virtual_lab.lab import VirtualLab

N_POSES = 30


def _video(path: Path, image: np.ndarray, frames: int = 40) -> Path:
    """A 1280x1024 MJPG video of a virtual-lab image moving sideways (camera-like content)."""
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), 15.0, (1280, 1024))
    base = cv2.cvtColor(cv2.resize(image, (1280, 1024)), cv2.COLOR_GRAY2BGR) if image.ndim == 2 else image
    for i in range(frames):
        writer.write(np.roll(base, 8 * i, axis=1))
    writer.release()
    return path


def _mean_capture(source, n: int) -> float:
    times = []
    for _ in range(n):
        t = time.perf_counter()
        source.capture()
        times.append(time.perf_counter() - t)
    return float(np.mean(times))


def _preview_fps(left: Path, right: Path, seconds: float = 3.0) -> tuple[float, float]:
    """(worker rate, shown rate) in pairs/s of the Setup page's preview of two video files: the
    worker grabs, decodes and shrinks both (unpaced), the Qt timer shows the newest pair."""
    from PySide6.QtCore import QCoreApplication, QEventLoop, QTimer

    from app.hardware import CameraChoice, LiveCameras
    from app.preview import PreviewPump

    QCoreApplication.instance() or QCoreApplication([])
    cams = LiveCameras.open(CameraChoice("sources", str(left), str(right)))
    try:
        pump = PreviewPump(cams, max_fps=0)
        grabbed = []
        pump.framesReady.connect(lambda *_: grabbed.append(1))
        t = time.perf_counter()
        pump.start()
        loop = QEventLoop()
        QTimer.singleShot(int(seconds * 1000), loop.quit)
        loop.exec()
        pump.stop()
        elapsed = time.perf_counter() - t
        worker = pump.grabbed / elapsed
        shown = pump.shown / elapsed
    finally:
        cams.close()
    return worker, shown


def run(report) -> None:
    lab = VirtualLab.create(seed=0)
    q = lab.random_visible_poses(1, np.random.default_rng(5))[0]
    rng = np.random.default_rng(1)
    pair = lab.render_marker_pair(q, rng)
    report.add("capture latency, virtual lab cameras (render a pair)",
               _mean_capture(RenderedSource(lambda: lab.render_marker_pair(q, rng)), 3), "<=", 1.0, "s")

    with tempfile.TemporaryDirectory(prefix="robocal-bench-") as tmp:
        tmp = Path(tmp)
        left, right = _video(tmp / "left.avi", pair[0]), _video(tmp / "right.avi", pair[1])
        with StereoSource(open_camera(str(left)), open_camera(str(right))) as source:
            report.add("capture latency, two 1280x1024 MJPG video files (grab + retrieve)",
                       _mean_capture(source, 30), "<=", 0.05, "s")
        worker_fps, shown_fps = _preview_fps(left, right)
        report.info("preview worker: grab + decode + shrink two 1280x1024 videos", worker_fps, "pairs/s")
        report.add("Setup preview of two 1280x1024 MJPG video files, pairs shown", shown_fps, ">=", 10.0,
                   "fps")

        model = lab.true_robot
        with ControllerSim(model, time_scale=1.0) as sim:
            driver = SerialRobot(model, sim.port, speed=100, reply_timeout=5.0, move_timeout=30.0)
            driver.connect()
            times = []
            for _ in range(200):
                t = time.perf_counter()
                driver.current_joints()
                times.append(time.perf_counter() - t)
            report.add("serial round trip POS? over a pty (median of 200)", float(np.median(times)) * 1e3,
                       "<=", 5.0, "ms")

            lo, hi = model.limits()
            Q = np.random.default_rng(2).uniform(np.maximum(lo, -0.6), np.minimum(hi, 0.6), (N_POSES, model.dof))
            poses = poses_from_internal(Q, model)
            with StereoSource(open_camera(str(left)), open_camera(str(right))) as cams:
                frames_left = iter(range(10 ** 6))

                def capture():
                    if next(frames_left) % 35 == 34:     # loop the video files
                        cams.left._cap.set(cv2.CAP_PROP_POS_FRAMES, 0)
                        cams.right._cap.set(cv2.CAP_PROP_POS_FRAMES, 0)
                    return cams.capture()

                def locate(left_img, right_img):
                    return SimpleNamespace(ok=True, reason="", point=np.array([1.0, 2.0, 600.0]),
                                           covariance=np.eye(3) * 1e-4, sigma=np.full(3, 0.01))

                t = time.perf_counter()
                result = run_measurements(poses, tmp / "meas.csv", locate=locate,
                                          source=SimpleNamespace(capture=capture), driver=driver)
                total = time.perf_counter() - t
            driver.disconnect()
            motion = sim.motion_seconds
    capture_s = sum(o.capture_seconds for o in result.outcomes)
    assert len(result.measured) == N_POSES and result.fault is None
    report.info(f"{N_POSES}-pose run over sim-robot (speed 100 %): total", total, "s")
    report.info("  motion time alone (simulator)", motion, "s")
    report.info("  capture time", capture_s, "s")
    report.add(f"{N_POSES}-pose run overhead over motion + capture", 100 * (total - motion - capture_s) /
               (motion + capture_s), "<=", 10.0, "%")
