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
