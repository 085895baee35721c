"""Capture sources on real video sources: a video file written with cv2.VideoWriter and an
image folder (no mocks of cv2.VideoCapture)."""
from __future__ import annotations

import cv2
import numpy as np
import pytest

from core.errors import RoboCalError
from core.measurement.capture import (CameraIdentity, FolderCamera, RenderedSource, StereoSource, VideoCamera,
                                      open_camera)

LEVELS = [20, 80, 140, 200, 240]


def write_video(path, levels, size=(320, 240)):
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), 10.0, size)
    assert writer.isOpened()
    for v in levels:
        writer.write(np.full((size[1], size[0], 3), v, np.uint8))
    writer.release()
    return path


def write_folder(folder, levels, size=(64, 48)):
    folder.mkdir()
    for i, v in enumerate(levels):
        cv2.imwrite(str(folder / f"img_{i:03d}.png"), np.full((size[1], size[0]), v, np.uint8))
    (folder / "notes.txt").write_text("not an image")
    return folder


def test_video_file_and_image_folder_as_a_stereo_pair(tmp_path):
    video = write_video(tmp_path / "left.avi", LEVELS)
    folder = write_folder(tmp_path / "right", LEVELS[::-1])
    left, right = open_camera(str(video)), open_camera(folder)
    assert isinstance(left, VideoCamera) and isinstance(right, FolderCamera) and not left.live
    assert left.identity == CameraIdentity("left.avi", str(video.resolve()))
    with StereoSource(left, right) as source:
        for i in range(len(LEVELS)):
            frames = source.capture()
            assert frames.left.shape == (240, 320, 3) and frames.right.shape == (48, 64)
            assert abs(float(frames.left.mean()) - LEVELS[i]) < 3          # MJPG is lossy
            assert int(frames.right[0, 0]) == LEVELS[::-1][i]
            assert frames.grab_gap_s >= 0.0 and frames.flushed == 0      # files hold no stale frames
        with pytest.raises(RoboCalError, match="no more images"):
            source.capture()


def test_swapped_cameras_are_noticed(tmp_path):
    a = write_folder(tmp_path / "a", LEVELS)
    b = write_folder(tmp_path / "b", LEVELS)
    source = StereoSource(FolderCamera(a), FolderCamera(b))
    before = source.identities()
    assert source.check_identities(before) == []
    swapped = StereoSource(FolderCamera(b), FolderCamera(a))
    assert swapped.check_identities(before) == ["the left and right cameras are swapped (cables exchanged)"]


def test_bad_sources_are_clear_errors(tmp_path):
    with pytest.raises(RoboCalError, match="no such camera, video file or image folder"):
        open_camera(tmp_path / "missing.avi")
    (tmp_path / "empty").mkdir()
    with pytest.raises(RoboCalError, match="the folder holds no images"):
        open_camera(tmp_path / "empty")
    (tmp_path / "broken.avi").write_bytes(b"not a video")
    with pytest.raises(RoboCalError, match="cannot open the camera or video"):
        open_camera(tmp_path / "broken.avi")


def test_rendered_pair_source():
    pair = (np.zeros((4, 4), np.uint8), np.ones((4, 4), np.uint8))
    frames = RenderedSource(lambda: pair).capture()
    assert frames.left is pair[0] and frames.right is pair[1] and frames.grab_gap_s == 0.0


def test_video_files_and_folders_rewind_to_their_first_frame(tmp_path):
    video = open_camera(str(write_video(tmp_path / "v.avi", LEVELS)))
    folder = open_camera(write_folder(tmp_path / "f", LEVELS))
    for cam in (video, folder):
        while cam.grab():
            cam.retrieve()
        assert cam.rewind()
        assert cam.grab()
        assert abs(float(cam.retrieve().mean()) - LEVELS[0]) < 3
        cam.close()


def test_the_pixel_format_is_set_before_width_and_height_and_automatic_modes_are_locked():
    from core.measurement.capture import CameraSettings, setting_steps
    steps = setting_steps(CameraSettings(width=1280, height=1024, fps=15))
    labels = [label for label, _, _ in steps]
    assert labels == ["pixel format", "width", "height", "frame rate", "auto exposure off", "auto focus",
                      "auto white balance off"]
    assert steps[0][2] == cv2.VideoWriter_fourcc(*"MJPG") and steps[5][2] == 0.0      # auto focus off
    steps = setting_steps(CameraSettings(pixel_format="YUYV", exposure=150, autofocus=True, focus=30,
                                         white_balance=4500, lock_exposure=False))
    assert [label for label, _, _ in steps] == ["pixel format", "auto exposure off", "exposure", "auto focus",
                                                "auto white balance off", "white balance"]
    assert dict((label, v) for label, _, v in steps)["auto focus"] == 1.0             # focus left to the camera
    assert [label for label, _, _ in setting_steps(CameraSettings(width=640), live=False)] == ["width"]


def test_settings_a_video_file_cannot_take_are_reported_with_its_actual_values(tmp_path):
    from core.measurement.capture import CameraSettings
    video = write_video(tmp_path / "left.avi", LEVELS)
    cam = open_camera(str(video), CameraSettings(width=1280, height=1024, fps=15, exposure=100))
    assert cam.settings["width"] == 320 and cam.settings["height"] == 240 and cam.settings["frame rate"] == 10
    assert cam.settings["pixel format"] == "MJPG"
    assert cam.warnings == [f"{video}: the video file refused width = 1280 (it uses 320)",
                            f"{video}: the video file refused height = 1024 (it uses 240)",
                            f"{video}: the video file refused frame rate = 15 (it uses 10)",
                            f"{video}: the video file refused exposure = 100 (it has no such control)"]
    assert open_camera(str(video)).warnings == []                  # nothing asked, nothing to report


def test_settings_an_image_folder_cannot_take_are_reported(tmp_path):
    from core.measurement.capture import CameraSettings
    folder = write_folder(tmp_path / "right", LEVELS)
    cam = open_camera(folder, CameraSettings(width=1280, gain=4))
    assert cam.settings == {"width": 64.0, "height": 48.0}
    assert cam.warnings == [f"{folder}: the image folder cannot take width = 1280 (its images have 64)",
                            f"{folder}: the image folder cannot take gain = 4"]


def test_usb_bandwidth_text_becomes_one_message():
    from core.measurement.capture import _bandwidth, _explain
    kernel = "[ WARN:0@1.2] global cap_v4l.cpp:1119 tryIoctl VIDEOIO(V4L2:/dev/video2): failed VIDIOC_STREAMON: " \
             "No space left on device"
    assert _bandwidth(kernel) and "not enough bandwidth" in _explain(kernel)
    assert not _bandwidth("VIDIOC_QBUF: Invalid argument") and _explain("anything") == ""


def test_a_stereo_pair_of_recordings_opens_and_a_missing_second_source_is_named(tmp_path):
    from core.measurement.capture import open_stereo
    video = write_video(tmp_path / "left.avi", LEVELS)
    with open_stereo(str(video), write_folder(tmp_path / "right", LEVELS)) as source:
        assert source.capture().left.shape == (240, 320, 3)
    with pytest.raises(RoboCalError) as info:
        open_stereo(str(video), tmp_path / "nothing.avi")
    assert "nothing.avi" in info.value.message and "USB" not in info.value.message
