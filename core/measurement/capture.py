"""Stereo capture sources: two cameras, each a device index, a device path (/dev/video2), a
video file, an image folder, or a rendered pair (the virtual lab's cameras, through a
function the app passes in).

Live cameras (cv2.VideoCapture): the pixel format is set before width and height (MJPG keeps
two USB cameras within the bus bandwidth), then frame rate, exposure, gain, focus and white
balance, all manual (auto focus off by default). Every `set()` is checked and the value the
camera really uses is read back: `camera.settings` holds the actual values and
`camera.warnings` a line for each setting that did not take.

`StereoSource.capture()` is called once the robot has settled: it drops the frames the
cameras buffered meanwhile (`flush` grabs), then `grab()`s both, then `retrieve()`s both,
and reports the time between the two grabs (s). A stream the USB bus cannot carry
(VIDIOC_STREAMON: No space left on device) becomes one clear message.
"""
from __future__ import annotations

import os
import re
import tempfile
import time
from abc import ABC, abstractmethod
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import cv2
import numpy as np

from core.errors import RoboCalError
from core.images import IMAGE_SUFFIXES

DEFAULT_FLUSH = 4          # frames a V4L2 camera typically buffers
USB_BANDWIDTH_HINT = ("Use the MJPG pixel format, a lower resolution or frame rate, or plug the two cameras "
                      "into different USB controllers")


@dataclass
class CameraSettings:
    """Wanted settings; None leaves the camera's own value. Exposure and gain in the
    driver's units (V4L2: exposure in 100 µs steps), white balance in kelvin. Exposure and
    white balance are locked to manual (at the camera's current value when none is given)
    unless `lock_exposure` / `lock_white_balance` is False."""

    width: int | None = None
    height: int | None = None
    pixel_format: str | None = "MJPG"
    fps: float | None = None
    exposure: float | None = None
    gain: float | None = None
    autofocus: bool = False
    focus: float | None = None
    white_balance: float | None = None
    lock_exposure: bool = True
    lock_white_balance: bool = True


@dataclass(frozen=True)
class CameraIdentity:
    """Who a camera is: its name and where it is plugged (bus path), to notice swapped cables."""

    name: str
    bus: str


@dataclass
class StereoFrames:
    left: np.ndarray
    right: np.ndarray
    grab_gap_s: float          # time between the two grabs (0 for a rendered pair)
    flushed: int = 0           # stale frames dropped per camera before the grab


class Camera(ABC):
    """One image source. `grab()` takes a frame (fast, no decoding), `retrieve()` decodes it."""

    live = False               # a live device buffers frames, which `flush` drops

    def __init__(self, spec):
        self.spec = spec
        self.settings: dict[str, float | str] = {}
        self.warnings: list[str] = []

    @property
    @abstractmethod
    def identity(self) -> CameraIdentity: ...

    @abstractmethod
    def grab(self) -> bool: ...

    @abstractmethod
    def retrieve(self) -> np.ndarray: ...

    def rewind(self) -> bool:
        """Start again from the first frame (a video file or an image folder, for a preview
        that loops); False for a live camera, which has no start."""
        return False

    def close(self) -> None:
        pass


class VideoCamera(Camera):
    """A device index, a device path or a video file, read with cv2.VideoCapture."""

    def __init__(self, spec: int | str | Path, settings: CameraSettings | None = None):
        super().__init__(spec)
        self.device = _device_path(spec)
        self.live = self.device is not None
        if not self.live and not Path(spec).is_file():
            raise RoboCalError("no such camera, video file or image folder", source=spec,
                               hint="Give a device index (0), a device path (/dev/video0), a video file or a folder.")
        target = int(spec) if isinstance(spec, int) or str(spec).isdigit() else str(spec)
        with _stderr_text() as err:
            self._cap = cv2.VideoCapture(target, cv2.CAP_V4L2) if self.live else cv2.VideoCapture(target)
        if not self._cap.isOpened():
            raise RoboCalError("cannot open the camera or video" + _explain(err()), source=spec,
                               hint=USB_BANDWIDTH_HINT if _bandwidth(err()) else "Check the cable, the path "
                               "and that no other program uses the camera.")
        self._apply(settings or CameraSettings())
        self._first = True

    @property
    def identity(self) -> CameraIdentity:
        if self.device is None:
            return CameraIdentity(Path(self.spec).name, str(Path(self.spec).resolve()))
        node = Path("/sys/class/video4linux") / Path(self.device).name
        try:
            name = (node / "name").read_text().strip()
        except OSError:
            name = Path(self.device).name
        bus = os.path.realpath(node / "device") if (node / "device").exists() else self.device
        return CameraIdentity(name, bus)

    def _apply(self, s: CameraSettings) -> None:
        """Each step of `setting_steps` set() and read back: `settings` holds what the source
        really uses, `warnings` a line per setting that did not take. A video file takes none
        of them (its images are recorded): the values asked for are reported as not taken."""
        cap = self._cap
        kind = "the camera" if self.live else "the video file"
        for label, prop, value in setting_steps(s, live=self.live):
            ok = cap.set(prop, float(value))
            actual = cap.get(prop)
            shown = _fourcc_text(actual) if prop == cv2.CAP_PROP_FOURCC else actual
            self.settings[label] = shown
            wanted = _fourcc_text(value) if prop == cv2.CAP_PROP_FOURCC else value
            if not ok:
                has = "it has no such control" if shown == -1 else f"it uses {_text(shown)}"
                self.warnings.append(f"{self.spec}: {kind} refused {label} = {_text(wanted)} ({has})")
            elif (shown != wanted) if prop == cv2.CAP_PROP_FOURCC else abs(float(actual) - float(value)) > 1e-6:
                self.warnings.append(f"{self.spec}: {label} = {_text(wanted)} did not take "
                                     f"({kind} uses {_text(shown)})")
        for label, prop in (("width", cv2.CAP_PROP_FRAME_WIDTH), ("height", cv2.CAP_PROP_FRAME_HEIGHT),
                            ("frame rate", cv2.CAP_PROP_FPS), ("pixel format", cv2.CAP_PROP_FOURCC)):
            if label not in self.settings:
                value = cap.get(prop)
                self.settings[label] = _fourcc_text(value) if prop == cv2.CAP_PROP_FOURCC else value

    def grab(self) -> bool:
        if self._first and self.live:
            with _stderr_text() as err:
                ok = self._cap.grab()
            self._first = False
            if not ok:
                raise RoboCalError("the camera gives no image" + _explain(err()), source=self.spec,
                                   hint=USB_BANDWIDTH_HINT if _bandwidth(err()) else "Check the cable and the camera.")
            return ok
        return self._cap.grab()

    def retrieve(self) -> np.ndarray:
        ok, frame = self._cap.retrieve()
        if not ok or frame is None:
            raise RoboCalError("no image to retrieve (end of the video?)", source=self.spec)
        return frame

    def rewind(self) -> bool:
        return not self.live and bool(self._cap.set(cv2.CAP_PROP_POS_FRAMES, 0))

    def close(self) -> None:
        self._cap.release()


class FolderCamera(Camera):
    """The images of a folder in sorted name order, one per grab. It takes no setting: the
    values asked for are reported as not taken, its size is the first image's."""

    def __init__(self, folder: str | Path, settings: CameraSettings | None = None):
        super().__init__(folder)
        self.files = sorted(p for p in Path(folder).iterdir() if p.suffix.lower() in IMAGE_SUFFIXES)
        if not self.files:
            raise RoboCalError("the folder holds no images", source=folder,
                               hint=f"Put {', '.join(IMAGE_SUFFIXES[:5])}, ... files in it.")
        self._next = 0
        self._current: Path | None = None
        first = cv2.imread(str(self.files[0]), cv2.IMREAD_UNCHANGED)
        if first is not None:
            self.settings = {"width": float(first.shape[1]), "height": float(first.shape[0])}
        for label, _, value in setting_steps(settings or CameraSettings(), live=False):
            has = f" (its images have {_text(self.settings[label])})" if label in self.settings else ""
            self.warnings.append(f"{folder}: the image folder cannot take {label} = {_text(value)}{has}")

    @property
    def identity(self) -> CameraIdentity:
        return CameraIdentity(Path(self.spec).name, str(Path(self.spec).resolve()))

    def grab(self) -> bool:
        if self._next >= len(self.files):
            return False
        self._current = self.files[self._next]
        self._next += 1
        return True

    def retrieve(self) -> np.ndarray:
        if self._current is None:
            raise RoboCalError("no image to retrieve (every image of the folder was used)", source=self.spec)
        image = cv2.imread(str(self._current), cv2.IMREAD_UNCHANGED)
        if image is None:
            raise RoboCalError("not a readable image", source=self._current)
        return image

    def rewind(self) -> bool:
        self._next, self._current = 0, None
        return True


def open_camera(spec, settings: CameraSettings | None = None) -> Camera:
    """A camera from a device index or path, a video file or an image folder."""
    if not isinstance(spec, int) and Path(str(spec)).is_dir():
        return FolderCamera(spec, settings)
    return VideoCamera(spec, settings)


def open_stereo(left_spec, right_spec, settings: CameraSettings | None = None) -> StereoSource:
    """Both cameras opened, each live one giving its first frame (so a stream the USB bus
    cannot carry fails here). When the second live camera fails while the first one runs, the
    message says what to change (MJPG, a lower resolution or frame rate, two USB controllers)."""
    left = open_camera(left_spec, settings)
    try:
        if left.live:
            left.grab()
        try:
            right = open_camera(right_spec, settings)
            if right.live:
                right.grab()
        except RoboCalError as exc:
            if left.live and _device_path(right_spec) is not None and exc.hint != USB_BANDWIDTH_HINT:
                raise RoboCalError(f"{exc.problem}; the first camera ({left.spec}) runs, so the USB bus likely "
                                   "has no bandwidth left for the second one", source=right_spec,
                                   hint=USB_BANDWIDTH_HINT) from None
            raise
    except BaseException:
        left.close()
        raise
    return StereoSource(left, right)


class StereoSource:
    """Two cameras captured together (left, right)."""

    def __init__(self, left: Camera, right: Camera, *, flush: int = DEFAULT_FLUSH):
        self.left, self.right = left, right
        self.flush = int(flush)

    @property
    def warnings(self) -> list[str]:
        return self.left.warnings + self.right.warnings

    def identities(self) -> tuple[CameraIdentity, CameraIdentity]:
        return self.left.identity, self.right.identity

    def check_identities(self, expected: tuple[CameraIdentity, CameraIdentity]) -> list[str]:
        """Lines describing what changed since `expected` (empty when the same cameras are in the
        same places); swapped cameras are named as such."""
        now = self.identities()
        if now == tuple(expected):
            return []
        if now == tuple(expected)[::-1]:
            return ["the left and right cameras are swapped (cables exchanged)"]
        return [f"{side} camera: was {e.name} at {e.bus}, now {n.name} at {n.bus}"
                for side, e, n in zip(("left", "right"), expected, now) if e != n]

    def capture(self) -> StereoFrames:
        """Drop stale frames, grab both, retrieve both (call it once the robot has settled)."""
        dropped = 0
        if self.left.live or self.right.live:
            for _ in range(self.flush):
                for cam in (self.left, self.right):
                    if cam.live:
                        cam.grab()
                dropped += 1
        t0 = time.perf_counter()
        ok_left = self.left.grab()
        t1 = time.perf_counter()
        ok_right = self.right.grab()
        if not (ok_left and ok_right):
            raise RoboCalError("no more images", source=self.left.spec if not ok_left else self.right.spec)
        return StereoFrames(self.left.retrieve(), self.right.retrieve(), t1 - t0, dropped)

    def close(self) -> None:
        self.left.close()
        self.right.close()

    def __enter__(self) -> "StereoSource":
        return self

    def __exit__(self, *exc) -> None:
        self.close()


@dataclass
class RenderedSource:
    """A stereo pair made by a function (the virtual lab's cameras: the app passes
    `lambda: lab.render_marker_pair(driver.current_joints(), rng)`)."""

    render: Callable[[], tuple[np.ndarray, np.ndarray]]
    warnings: list[str] = field(default_factory=list)

    def capture(self) -> StereoFrames:
        left, right = self.render()
        return StereoFrames(left, right, 0.0)

    def close(self) -> None:
        pass


# -- helpers -------------------------------------------------------------------------------------

def setting_steps(s: CameraSettings, *, live: bool = True) -> list[tuple[str, int, float]]:
    """(label, cv2 property, value) in the order they are set: the pixel format BEFORE width
    and height (a format change resets the size; MJPG first keeps two cameras within the USB
    bandwidth), then frame rate, exposure, gain, focus and white balance with their automatic
    modes off. For a recording (`live` False) only the values asked for: it has no automatic
    modes and no format to choose."""
    steps: list[tuple[str, int, float | None]] = []
    if live and s.pixel_format:
        steps.append(("pixel format", cv2.CAP_PROP_FOURCC, cv2.VideoWriter_fourcc(*s.pixel_format[:4].ljust(4))))
    steps += [("width", cv2.CAP_PROP_FRAME_WIDTH, s.width), ("height", cv2.CAP_PROP_FRAME_HEIGHT, s.height),
              ("frame rate", cv2.CAP_PROP_FPS, s.fps)]
    if live and (s.lock_exposure or s.exposure is not None):
        steps.append(("auto exposure off", cv2.CAP_PROP_AUTO_EXPOSURE, 1))       # V4L2_EXPOSURE_MANUAL
    steps += [("exposure", cv2.CAP_PROP_EXPOSURE, s.exposure), ("gain", cv2.CAP_PROP_GAIN, s.gain)]
    if live:
        steps.append(("auto focus", cv2.CAP_PROP_AUTOFOCUS, 1 if s.autofocus else 0))
    if not s.autofocus:
        steps.append(("focus", cv2.CAP_PROP_FOCUS, s.focus))
    if live and (s.lock_white_balance or s.white_balance is not None):
        steps.append(("auto white balance off", cv2.CAP_PROP_AUTO_WB, 0))
    steps.append(("white balance", cv2.CAP_PROP_WB_TEMPERATURE, s.white_balance))
    return [(label, prop, float(value)) for label, prop, value in steps if value is not None]


def _device_path(spec) -> str | None:
    if isinstance(spec, int) or str(spec).isdigit():
        return f"/dev/video{int(spec)}"
    text = str(spec)
    return text if text.startswith("/dev/") else None


def _text(value) -> str:
    return f"{value:g}" if isinstance(value, float) else str(value)


def _fourcc_text(value: float) -> str:
    code = int(value)
    return "".join(chr((code >> 8 * i) & 0xFF) for i in range(4))


def _bandwidth(text: str) -> bool:
    return bool(re.search(r"VIDIOC_STREAMON.*No space left on device", text))


def _explain(text: str) -> str:
    if _bandwidth(text):
        return ": the USB bus has not enough bandwidth for this stream (VIDIOC_STREAMON: No space left on device)"
    return ""


@contextmanager
def _stderr_text():
    """Collect what native code (OpenCV's V4L2 backend) writes to stderr meanwhile, and pass it on."""
    collected = [""]
    try:
        saved = os.dup(2)
    except OSError:
        yield lambda: ""
        return
    with tempfile.TemporaryFile() as tmp:
        os.dup2(tmp.fileno(), 2)
        try:
            yield lambda: collected[0]
        finally:
            os.dup2(saved, 2)
            os.close(saved)
            tmp.seek(0)
            collected[0] = tmp.read().decode("utf-8", "replace")
            if collected[0]:
                os.write(2, collected[0].encode("utf-8"))
