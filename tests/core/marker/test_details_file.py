"""marker_details.json as a typed record: what is written is read back field for field (with
the crops beside it in the same write), and a damaged file is refused naming the file and field."""
import json

import pytest

from core.errors import RoboCalError
from core.marker.details_file import DETAILS_FILE, DETAILS_FORMAT, LIVE_IMAGES, MarkerDetails

LIVE = {"pair": 3, "error_mm": 0.0123, "point_mm": [10.5, -4.25, 702.0], "sigma_mm": None, "disparity_px": 50.31,
        "images": {"left": {"file": LIVE_IMAGES["left"], "origin": [412, 300], "scale": 0.5, "found": True}}}
VERIFICATION = {"poses": 3, "located": 2, "stereo": "stereo.json", "depth_mm": [600.0, 650.0, 700.0],
                "errors_mm": [0.012, None, 0.031], "sigmas_mm": [0.01, None, 0.014],
                "median_error_mm": 0.0215, "rms_error_mm": 0.0235}


def test_a_record_written_is_read_back_with_its_crops(tmp_path):
    path = tmp_path / DETAILS_FILE
    crop = tmp_path / LIVE_IMAGES["left"]
    written = MarkerDetails("marker.npz", live=LIVE, verification=VERIFICATION)
    written.write(path, also={crop: b"\x89PNG crop bytes"})
    assert crop.read_bytes() == b"\x89PNG crop bytes"
    assert json.loads(path.read_text())["format"] == DETAILS_FORMAT
    read = MarkerDetails.read(path)
    assert read == written and read.verification["errors_mm"][1] is None
    assert read.to_dict() == {"format": DETAILS_FORMAT, "marker": "marker.npz", "live": LIVE,
                              "verification": VERIFICATION}
    only_live = MarkerDetails("marker.npz", live=LIVE)
    only_live.write(path)
    assert MarkerDetails.read(path) == only_live and "verification" not in json.loads(path.read_text())


@pytest.mark.parametrize("change, field, words", [
    ({"format": "robocal.marker_details/9"}, "format", "robocal.marker_details/9"),
    ({"marker": 7}, "marker", "marker's file name"),
    ({"live": [1, 2]}, "live", "expected an object"),
    ({"live": {"pair": 1}}, "live.images", "missing"),
    ({"verification": {**VERIFICATION, "poses": "three"}}, "verification.poses", "number of poses"),
    ({"verification": {**VERIFICATION, "errors_mm": [0.1]}}, "verification.errors_mm", "one value per pose (3)"),
])
def test_a_bad_file_is_refused_naming_the_file_and_field(tmp_path, change, field, words):
    path = tmp_path / DETAILS_FILE
    path.write_text(json.dumps({**MarkerDetails("marker.npz", LIVE, VERIFICATION).to_dict(), **change}))
    with pytest.raises(RoboCalError) as caught:
        MarkerDetails.read(path)
    assert caught.value.source == str(path) and caught.value.field == field
    assert words in caught.value.message and "Marker page" in caught.value.message


def test_a_file_that_is_not_an_object_is_refused(tmp_path):
    path = tmp_path / DETAILS_FILE
    path.write_text("[1, 2]")
    with pytest.raises(RoboCalError, match=DETAILS_FILE):
        MarkerDetails.read(path)
