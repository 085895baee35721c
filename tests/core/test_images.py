"""core.images: every image format RoboCal reads becomes the same 8-bit grayscale."""
import cv2
import numpy as np
import pytest

from core.errors import RoboCalError
from core.images import decode_gray, encode_png, require_gray8, to_gray8
from core.marker.training import train_marker


def test_formats_become_8_bit_gray():
    gray = np.arange(256, dtype=np.uint8).reshape(16, 16)
    bgr = cv2.cvtColor(gray, cv2.COLOR_GRAY2BGR)
    assert np.array_equal(to_gray8(bgr), gray)
    assert np.array_equal(to_gray8(cv2.cvtColor(bgr, cv2.COLOR_BGR2BGRA)), gray)
    assert np.array_equal(to_gray8(gray.astype(np.uint16) << 8), gray)          # 16 bit
    assert np.array_equal(to_gray8(gray[:, :, None]), gray)
    assert to_gray8(gray.astype(np.float32) / 255.0).max() == 255                 # float, stretched
    ok, png16 = cv2.imencode(".png", gray.astype(np.uint16) << 8)
    assert np.array_equal(decode_gray(png16.tobytes())[0], gray)


def test_missing_or_shapeless_images_are_refused_clearly():
    with pytest.raises(RoboCalError, match="no left image"):
        require_gray8(None, "left image")
    with pytest.raises(RoboCalError, match="not an image"):
        require_gray8(np.zeros(5), "left image")


def test_png_encoding_keeps_every_grey_level_and_refuses_what_png_cannot_hold(tmp_path):
    noisy = np.random.default_rng(0).integers(0, 256, (48, 64), dtype=np.uint8)
    data = encode_png(noisy)
    assert data[:8] == b"\x89PNG\r\n\x1a\n"
    assert np.array_equal(decode_gray(data)[0], noisy)
    bgr = cv2.cvtColor(noisy, cv2.COLOR_GRAY2BGR)
    assert np.array_equal(cv2.imdecode(np.frombuffer(encode_png(bgr), np.uint8), cv2.IMREAD_UNCHANGED), bgr)
    for bad in (np.zeros((0, 0), np.uint8), np.zeros((4, 4, 2), np.uint8)):
        with pytest.raises(RoboCalError, match="could not encode the left image as PNG") as err:
            encode_png(bad, "the left image", tmp_path / "pair_001.png")
        assert "pair_001.png" in str(err.value)


def test_a_16_bit_training_image_trains_like_the_8_bit_one(built_lab):
    image = built_lab(seed=0).render_training_image()
    eight = train_marker(image)
    sixteen = train_marker(image.astype(np.uint16) << 8)       # an industrial camera's 16-bit PNG
    np.testing.assert_allclose(sixteen.outline, eight.outline, atol=1e-9)
    assert sixteen.n_features == eight.n_features
