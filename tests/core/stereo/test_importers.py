"""Stereo calibrations from other tools: each format, written as the tool writes it, reads into
the same cameras and pose (the same pixels for the same 3D points, ≤ 1e-6 px), with E, F and the
rectification computed where absent and statistics unknown; refusals are one clear message."""
from __future__ import annotations

import json
from pathlib import Path

import cv2
import numpy as np
import pytest
import scipy.io.matlab
from scipy.io import loadmat, savemat

from app.cli import main
from core.errors import RoboCalError
from core.stereo.file import read_stereo_yaml, write_stereo_yaml
from core.stereo.importers import read_any_stereo
from core.stereo.importers.kalibr import RECALIBRATE
from core.stereo.rectification import load_rectification
from tests.core.stereo import foreign_files as ff
from tests.core.stereo_synth import REAL_DATA, real_pairs


@pytest.fixture(scope="module")
def rig():
    from core.virtual_lab.rig import default_rig
    return default_rig(0)


PARABOLA = Path(scipy.io.matlab.__file__).parent / "tests" / "data" / "parabola.mat"
POINTS = np.column_stack([np.linspace(-300, 300, 40), np.linspace(-200, 250, 40)[::-1],
                          np.linspace(700, 1800, 40)])


def assert_same_pixels(imported, rig, tol=1e-6):
    """The imported pair projects the same 3D points (left frame, mm) to the same pixels."""
    got = imported.file.rig.project(POINTS)
    want = rig.project(POINTS)
    for g, w in zip(got, want):
        assert np.abs(g - w).max() <= tol, np.abs(g - w).max()


def assert_unknown_statistics(imported):
    sf = imported.file
    assert sf.rms_left is None and sf.rms_right is None and sf.rms_stereo is None and sf.board is None


def test_plain_opencv_yaml_with_rectification(tmp_path, rig):
    path = ff.opencv_file(rig, tmp_path / "stereo.yml")
    imported = read_any_stereo(path)
    assert imported.kind == "OpenCV FileStorage" and imported.file.image_size == rig.left.size
    assert_same_pixels(imported, rig)
    assert_unknown_statistics(imported)
    R1, R2, P1, P2, Q = ff.rectify(rig)
    np.testing.assert_array_equal(imported.file.P2, P2)           # kept as the file gave it
    assert any("E, F" in n for n in imported.notes)                # E and F computed


def test_plain_opencv_xml_with_m1_m2_and_no_rectification(tmp_path, rig):
    path = ff.opencv_file(rig, tmp_path / "stereo.xml", rectification=False, camera_names=("M1", "M2"))
    imported = read_any_stereo(path)
    assert_same_pixels(imported, rig)
    R1, R2, P1, P2, Q = ff.rectify(rig)
    np.testing.assert_allclose(imported.file.P2, P2, rtol=1e-12, atol=1e-9)   # computed by cv2.stereoRectify
    np.testing.assert_allclose(imported.file.Q, Q, rtol=1e-12, atol=1e-12)


def test_opencv_file_locates_like_robocal_stereo_yaml(tmp_path, rig):
    path = ff.opencv_file(rig, tmp_path / "stereo.yml")
    ours = load_rectification(write_stereo_yaml(tmp_path / "robocal.yaml", read_any_stereo(path).file))
    theirs = load_rectification(path)
    for key in ("R1", "R2", "P1", "P2"):
        np.testing.assert_array_equal(getattr(ours, key), getattr(theirs, key))


def test_stereo_calib_intrinsics_and_extrinsics(tmp_path, rig):
    intrinsics, extrinsics = ff.stereo_calib_pair(rig, tmp_path)
    for given in ([intrinsics, extrinsics], [extrinsics, intrinsics], intrinsics, extrinsics, tmp_path):
        imported = read_any_stereo(given)
        assert_same_pixels(imported, rig)
        assert imported.file.image_size == (1280, 1024)          # the common size nearest 2·(634.0, 505.7)
        assert any("no image size" in n for n in imported.notes)
    sized = read_any_stereo(tmp_path, image_size=(1280, 1024))
    assert not any("no image size" in n for n in sized.notes)
    half = read_any_stereo(tmp_path, image_size=(1280, 1024), mm_per_unit=0.5)
    assert half.file.baseline_mm == pytest.approx(rig.baseline / 2, rel=1e-12)
    np.testing.assert_allclose(half.file.P2[0, 3], ff.rectify(rig)[3][0, 3] / 2, rtol=1e-12)


def _rewrite_extrinsics(path: Path, keep: tuple[str, ...], scale: float = 1.0) -> None:
    """extrinsics.yml again with only the `keep` keys (P's last column and T times `scale`)."""
    fs = cv2.FileStorage(str(path), cv2.FILE_STORAGE_READ)
    mats = {k: fs.getNode(k).mat() for k in keep}
    fs.release()
    fs = cv2.FileStorage(str(path), cv2.FILE_STORAGE_WRITE)
    for key, m in mats.items():
        m = m.copy()
        if key in ("P1", "P2"):
            m[:, 3] *= scale
        elif key == "T":
            m *= scale
        fs.write(key, m)
    fs.release()


@pytest.mark.parametrize("vertical", [False, True])
def test_stereo_calib_extrinsics_with_only_the_rectification(tmp_path, rig, vertical):
    """R1, P1, R2, P2 without R, T (MultiSense's ImageCalUtility writes them so): the pose is
    R2ᵀ·R1, R2ᵀ·(t2 − t1), side by side or one camera above the other."""
    from core.stereo.rig import StereoRig

    pair = StereoRig(rig.left, rig.right, rig.R, [rig.T[1], -rig.baseline, rig.T[2]]) if vertical else rig
    intrinsics, extrinsics = ff.stereo_calib_pair(pair, tmp_path)
    _rewrite_extrinsics(extrinsics, ("R1", "P1", "R2", "P2"))
    imported = read_any_stereo([intrinsics, extrinsics], image_size=(1280, 1024))
    np.testing.assert_allclose(imported.file.R, pair.R, atol=1e-12)
    np.testing.assert_allclose(imported.file.T, pair.T, rtol=1e-12, atol=1e-9)
    assert any("from the rectification R1, R2, P1, P2" in n for n in imported.notes)


def test_stereo_calib_extrinsics_in_metres_or_without_t_are_refused(tmp_path, rig, capsys):
    intrinsics, extrinsics = ff.stereo_calib_pair(rig, tmp_path)
    _rewrite_extrinsics(extrinsics, ("R", "T", "R1", "R2", "P1", "P2"), scale=1e-3)    # square size in m
    with pytest.raises(RoboCalError, match=r"field 'T': the cameras are 0.\d+ mm apart, too close .*--unit m"):
        read_any_stereo(tmp_path)
    metres = read_any_stereo(tmp_path, mm_per_unit=1000.0)
    assert metres.file.baseline_mm == pytest.approx(rig.baseline, rel=1e-12)
    _rewrite_extrinsics(extrinsics, ("R", "R1", "R2", "P1", "P2"))
    with pytest.raises(RoboCalError, match=r"extrinsics.yml: field 'T': missing\. Give R and T"):
        read_any_stereo(tmp_path)


def test_stereo_calib_intrinsics_alone_is_refused(tmp_path, rig):
    intrinsics, extrinsics = ff.stereo_calib_pair(rig, tmp_path)
    extrinsics.unlink()
    with pytest.raises(RoboCalError, match=r"intrinsics.yml: holds only the cameras .* no extrinsics.yml"):
        read_any_stereo(intrinsics)


def test_ros_camera_info_pair(tmp_path, rig):
    left, right = ff.ros_pair(rig, tmp_path)
    for given in ([left, right], tmp_path):
        imported = read_any_stereo(given)
        assert imported.kind == "ROS camera_info pair"
        assert_same_pixels(imported, rig)
        assert_unknown_statistics(imported)
        np.testing.assert_allclose(imported.file.T, rig.T, rtol=0, atol=1e-9)
        np.testing.assert_allclose(imported.file.R, rig.R, rtol=0, atol=1e-12)


def test_ros_pair_with_the_pose_given(tmp_path, rig):
    left, right = ff.ros_pair(rig, tmp_path, with_baseline=False)
    with pytest.raises(RoboCalError,
                       match=r"right.yaml: field 'projection_matrix': .* holds no baseline.*Give the pose"):
        read_any_stereo([left, right])
    _, extrinsics = ff.stereo_calib_pair(rig, tmp_path)
    imported = read_any_stereo([left, right, extrinsics])
    assert_same_pixels(imported, rig)
    np.testing.assert_allclose(imported.file.P2, ff.rectify(rig)[3], rtol=1e-12, atol=1e-9)


def test_ros_refusals(tmp_path, rig):
    left, right = ff.ros_pair(rig, tmp_path, model="equidistant")
    with pytest.raises(RoboCalError, match=r"left.yaml: field 'distortion_model': distortion model 'equidistant' "
                                           r"is not supported"):
        read_any_stereo([left, right])
    left, right = ff.ros_pair(rig, tmp_path)
    with pytest.raises(RoboCalError, match="left.yaml: a ROS camera_info file holds one camera"):
        read_any_stereo(left)


def test_kalibr_camchain(tmp_path, rig):
    imported = read_any_stereo(ff.kalibr_camchain(rig, tmp_path / "camchain-stereo.yaml"))
    assert imported.kind == "Kalibr camchain"
    assert_same_pixels(imported, rig)
    assert_unknown_statistics(imported)
    assert read_any_stereo(tmp_path).file.baseline_mm == pytest.approx(rig.baseline, rel=1e-12)


@pytest.mark.parametrize("kwargs, field", [({"model": "equidistant"}, "cam0.distortion_model"),
                                           ({"model": "fov"}, "cam0.distortion_model"),
                                           ({"camera_model": "omni"}, "cam0.camera_model")])
def test_kalibr_refuses_other_models(tmp_path, rig, capsys, kwargs, field):
    """One line naming the camchain, the camera's field and what to do: calibrate again with
    pinhole-radtan, in Kalibr or in RoboCal."""
    path = ff.kalibr_camchain(rig, tmp_path / "camchain.yaml", **kwargs)
    with pytest.raises(RoboCalError) as err:
        read_any_stereo(path)
    says = "equidistant (fisheye) lens model" if kwargs.get("model") == "equidistant" else "not supported"
    assert err.value.field == field and says in err.value.message and "pinhole" in err.value.message
    assert err.value.hint == RECALIBRATE
    assert main(["stereo-import", str(path), "--out", str(tmp_path / "stereo.yaml")]) == 1
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1 and str(path) in lines[0] and f"'{field}'" in lines[0] and RECALIBRATE in lines[0]


@pytest.mark.parametrize("units", ["mm", "meters"])
def test_matlab_stereo_parameters_json(tmp_path, rig, units):
    imported = read_any_stereo(ff.matlab_json(rig, tmp_path / "stereoParams.json", units=units))
    assert imported.kind == "MATLAB stereoParameters (JSON)"
    assert_same_pixels(imported, rig)
    np.testing.assert_allclose(imported.file.K1, rig.left.K, rtol=1e-15)     # transposed back, −1 px
    assert_unknown_statistics(imported)


def test_matlab_refusals(tmp_path, rig):
    with pytest.raises(RoboCalError, match=r"field 'CameraParameters1.IntrinsicMatrix': the skew is 2"):
        read_any_stereo(ff.matlab_json(rig, tmp_path / "skew.json", skew=2.0))
    path = ff.matlab_json(rig, tmp_path / "untransposed.json")
    data = json.loads(path.read_text())
    data["RotationOfCamera2"] = (np.asarray(data["RotationOfCamera2"]) * 2).tolist()
    path.write_text(json.dumps(data))
    with pytest.raises(RoboCalError, match=r"field 'RotationOfCamera2': not a rotation matrix"):
        read_any_stereo(path)


@pytest.mark.parametrize("options", [
    {},                                                                     # toStruct saved as variable s
    {"layout": "fields", "intrinsics": "K", "pose": "PoseCamera2", "units": "meters"},
    {"intrinsics": "Intrinsics", "pose": "PoseCamera2", "radial": 2},
    {"layout": "fields", "intrinsics": "K", "radial": 6},
])
def test_matlab_stereo_parameters_mat(tmp_path, options):
    """MAT-files as MATLAB saves toStruct(stereoParams): the same pixels as the true cameras."""
    from core.virtual_lab.rig import default_rig

    radial = options.get("radial", 3)
    distortion = {2: (-0.1, 0.05, 0.001, -0.0005, 0.0), 3: (-0.1, 0.05, 0.001, -0.0005, 0.01),
                  6: (-0.1, 0.05, 0.001, -0.0005, 0.01, 0.02, -0.01, 0.005)}[radial]
    rig = default_rig(1)
    for cam in (rig.left, rig.right):
        cam.dist = np.array(distortion)
    path = ff.matlab_mat(rig, tmp_path / "stereo.mat", **options)
    imported = read_any_stereo(path)
    assert imported.kind == "MATLAB stereoParameters (MAT)" and imported.sources == [path]
    assert imported.file.image_size == rig.left.size
    assert_same_pixels(imported, rig)
    np.testing.assert_allclose(imported.file.K1, rig.left.K, rtol=1e-15)      # −1 px, transposed back
    np.testing.assert_allclose(imported.file.T, rig.T, rtol=0, atol=1e-12)    # in mm, whatever the unit
    assert imported.file.D1.size == (8 if radial == 6 else 5)
    assert_unknown_statistics(imported)


def test_matlab_mat_and_json_read_alike(tmp_path, rig):
    """One place for MATLAB's conventions: the MAT-file and the JSON export give the same file."""
    mat = read_any_stereo(ff.matlab_mat(rig, tmp_path / "stereo.mat")).file
    json_file = read_any_stereo(ff.matlab_json(rig, tmp_path / "stereo.json")).file
    assert mat.to_dict() == json_file.to_dict()


def _v73(path):
    """The start of a MAT-file 7.3 as MATLAB writes it: a 128-byte text header (version 0x0200,
    'IM'), padded to a 512-byte user block, then the HDF5 signature."""
    text = b"MATLAB 7.3 MAT-file, Platform: GLNXA64, Created on: Mon Jan  1 00:00:00 2024 HDF5 schema 1.00 ."
    header = text.ljust(116, b" ") + bytes(8) + b"\x00\x02IM"
    path.write_bytes(header.ljust(512, b"\x00") + b"\x89HDF\r\n\x1a\n" + bytes(64))
    return path


def test_matlab_mat_refusals(tmp_path, rig):
    with pytest.raises(RoboCalError, match=r"v73.mat: a MAT-file version 7.3 \(HDF5\).*'-v7'"):
        read_any_stereo(_v73(tmp_path / "v73.mat"))
    (tmp_path / "text.mat").write_text("K1: [1, 2]\n")
    with pytest.raises(RoboCalError, match=r"text.mat: not a MATLAB MAT-file"):
        read_any_stereo(tmp_path / "text.mat")
    savemat(tmp_path / "other.mat", {"a": np.eye(3), "b": "text"})
    with pytest.raises(RoboCalError, match=r"other.mat: holds no stereoParameters struct .* variables: a, b\. "
                                           r"Save the stereo parameters"):
        read_any_stereo(tmp_path / "other.mat")
    s = loadmat(ff.matlab_mat(rig, tmp_path / "s.mat"), simplify_cells=True)["s"]
    savemat(tmp_path / "two.mat", {"s": s, "t": s})
    with pytest.raises(RoboCalError, match=r"two.mat: holds several stereo calibrations \(s, t\)"):
        read_any_stereo(tmp_path / "two.mat")


def _edited(rig, path, edit, **options):
    """A MAT-file of the rig with its struct s edited."""
    s = loadmat(ff.matlab_mat(rig, path, **options), simplify_cells=True)["s"]
    edit(s)
    savemat(path, {"s": s})
    return path


@pytest.mark.parametrize("edit, field, says", [
    (lambda s: s.pop("CameraParameters2"), "s.CameraParameters2", "missing"),
    (lambda s: s.pop("TranslationOfCamera2"), "s.TranslationOfCamera2", "missing"),
    (lambda s: s["CameraParameters1"].pop("IntrinsicMatrix"), "s.CameraParameters1.K",
     r"missing \(the camera needs K, IntrinsicMatrix or Intrinsics\)"),
    (lambda s: s["CameraParameters2"].pop("ImageSize"), "s.CameraParameters2.ImageSize", "missing"),
    (lambda s: s.update(RotationOfCamera2=np.eye(3)[:2]), "s.RotationOfCamera2", "expected 3x3 numbers, got 6"),
    (lambda s: s["CameraParameters1"].update(RadialDistortion=np.zeros(4)), "s.CameraParameters1.RadialDistortion",
     "expected 2, 3 or 6 coefficients, got 4"),
    (lambda s: s["CameraParameters1"].update(ImageSize=np.array([1024.0, 1280.0, 3.0])),
     "s.CameraParameters1.ImageSize", r"expected \[rows cols\]"),
    (lambda s: s["CameraParameters2"].update(MappingCoefficients=np.array([800.0, 0.0, 0.0, 0.0])),
     "s.CameraParameters2.MappingCoefficients", "a fisheye camera model"),
    (lambda s: s.update(RotationOfCamera2=2 * s["RotationOfCamera2"]), "s.RotationOfCamera2", "not a rotation matrix"),
    (lambda s: s["CameraParameters1"].update(WorldUnits="furlongs"), "s.CameraParameters1.WorldUnits",
     "unknown world unit 'furlongs'"),
])
def test_matlab_mat_bad_fields(tmp_path, rig, edit, field, says):
    path = _edited(rig, tmp_path / "stereo.mat", edit)
    with pytest.raises(RoboCalError, match=rf"stereo.mat: field '{field}': {says}") as err:
        read_any_stereo(path)
    assert err.value.field == field and "\n" not in err.value.message


def test_matlab_mat_pose_fields(tmp_path, rig):
    path = _edited(rig, tmp_path / "stereo.mat", lambda s: s["PoseCamera2"].pop("Translation"), pose="PoseCamera2")
    with pytest.raises(RoboCalError, match=r"field 's.PoseCamera2.Translation': missing"):
        read_any_stereo(path)
    path = _edited(rig, tmp_path / "stereo.mat", lambda s: s["CameraParameters1"]["Intrinsics"].pop("PrincipalPoint"),
                   intrinsics="Intrinsics")
    with pytest.raises(RoboCalError, match=r"field 's.CameraParameters1.Intrinsics.PrincipalPoint': missing"):
        read_any_stereo(path)


@pytest.mark.skipif(not PARABOLA.is_file(), reason="scipy's test MAT-files are not installed")
def test_matlab_object_in_a_mat_file_is_refused(tmp_path):
    """A MATLAB object (here a function handle saved by MATLAB) can be read only by MATLAB."""
    path = tmp_path / "stereoParams.mat"
    path.write_bytes(PARABOLA.read_bytes())
    with pytest.raises(RoboCalError, match=r"variable 'parabola' is a MATLAB object, which only MATLAB can read. "
                                           r"Save the struct .* toStruct\(stereoParams\)"):
        read_any_stereo(path)


def test_robocal_stereo_yaml_still_read(tmp_path, rig):
    sf = read_any_stereo(ff.opencv_file(rig, tmp_path / "s.yml")).file
    path = write_stereo_yaml(tmp_path / "stereo.yaml", sf)
    imported = read_any_stereo(path)
    assert imported.kind == "RoboCal stereo.yaml"
    again = read_stereo_yaml(path)
    assert again.to_dict() == sf.to_dict() and again.rms_stereo is None and again.board is None
    assert "rms_stereo" not in path.read_text() and "board_cols" not in path.read_text()   # unknown: never 0


def test_unrecognised_files(tmp_path):
    other = tmp_path / "other.yaml"
    other.write_text("name: something\nvalues: [1, 2]\n")
    with pytest.raises(RoboCalError, match="other.yaml: not a stereo calibration RoboCal recognises"):
        read_any_stereo(other)
    with pytest.raises(RoboCalError, match="no stereo calibration found in this folder"):
        read_any_stereo(tmp_path / ".")
    with pytest.raises(RoboCalError, match="file not found"):
        read_any_stereo(tmp_path / "none.yaml")


@pytest.mark.parametrize("edit, says", [
    (lambda t: t.replace("   cols: 3\n", "", 1), "expected an OpenCV matrix"),
    (lambda t: t.replace("   rows: 3\n   cols: 3\n", "   rows: 3\n   cols: 4\n", 1), "needs 12 values in data, got 9"),
    (lambda t: t.replace("   rows: 3\n", "   rows: 1000000\n", 1), "at most 16x16"),
    (lambda t: t.replace("   dt: d\n", "   dt: 3d\n", 1), None),
    (lambda t: t.replace("data: [ ", "data: [ x, ", 1), "needs 9 values"),
])
def test_malformed_matrices_are_refused_without_harm(tmp_path, rig, edit, says):
    """cv2.FileNode.mat() writes past its buffer when rows·cols and data disagree: the
    matrix is checked and built from its entries instead (read many times: no heap damage)."""
    intrinsics, _ = ff.stereo_calib_pair(rig, tmp_path)
    intrinsics.write_text(edit(intrinsics.read_text()))
    expected = f"intrinsics.yml: field 'M1': .*{says}" if says else "intrinsics.yml: not a readable OpenCV"
    for _ in range(50):
        with pytest.raises(RoboCalError, match=expected):
            read_any_stereo(intrinsics)


@pytest.mark.skipif(not REAL_DATA.is_dir(), reason="real checkerboard pairs not present (../shared/data)")
def test_stereo_calib_output_of_real_pairs(tmp_path):
    """The real 640x512 pairs calibrated as OpenCV's stereo_calib sample does it (plain
    cv2.stereoCalibrate, 24 mm squares), written as its intrinsics.yml + extrinsics.yml: the
    import infers 640x512 and reproduces the pixels of the calibration."""
    import cv2

    from core.camera import CameraModel
    from core.stereo.rig import StereoRig

    board = np.zeros((54, 3), np.float32)
    board[:, :2] = np.mgrid[0:9, 0:6].T.reshape(-1, 2) * 24.0
    objects, lefts, rights = [], [], []
    for left, right in real_pairs(range(1, 13)):
        found = []
        for path in (left, right):
            gray = cv2.imread(str(path), cv2.IMREAD_GRAYSCALE)
            ok, corners = cv2.findChessboardCorners(gray, (9, 6))
            if ok:
                corners = cv2.cornerSubPix(gray, corners, (11, 11), (-1, -1),
                                           (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_COUNT, 30, 0.01))
            found.append(corners if ok else None)
        if found[0] is not None and found[1] is not None:
            objects.append(board)
            lefts.append(found[0])
            rights.append(found[1])
    size = (640, 512)
    rms, K1, D1, K2, D2, R, T, _, _ = cv2.stereoCalibrate(
        objects, lefts, rights, None, None, None, None, size, flags=cv2.CALIB_FIX_ASPECT_RATIO
        | cv2.CALIB_ZERO_TANGENT_DIST | cv2.CALIB_SAME_FOCAL_LENGTH,
        criteria=(cv2.TERM_CRITERIA_COUNT + cv2.TERM_CRITERIA_EPS, 100, 1e-5))
    rig = StereoRig(CameraModel(K1, D1.ravel(), *size), CameraModel(K2, D2.ravel(), *size), R, T)
    ff.stereo_calib_pair(rig, tmp_path)
    imported = read_any_stereo(tmp_path / "intrinsics.yml")
    assert imported.file.image_size == size and any("640x512 px assumed" in n for n in imported.notes)
    assert 85 < imported.file.baseline_mm < 100 and rms < 1.0          # the README's T: (91.2, −2.65, 12.2) mm
    assert imported.file.T[0] > 0
    assert_same_pixels(imported, rig)
    np.testing.assert_array_equal(imported.file.P2, ff.rectify(rig)[3])
    # in these pairs the 'left' images come from the camera on the right (T_x > 0, as the README's T):
    # the marker location refuses the rig with what to do
    with pytest.raises(RoboCalError, match=r"'right' camera is on the left .* Swap the left and right images"):
        load_rectification(tmp_path)


def test_singular_matrices_are_refused_before_anything_is_computed(tmp_path, rig):
    """Zero focal lengths or a singular projection matrix: one message, no numerical error."""
    chain = ff.kalibr_camchain(rig, tmp_path / "camchain.yaml")
    text = chain.read_text()
    start = text.index("  intrinsics: [")
    chain.write_text(text[:start] + "  intrinsics: [0.0, 0.0, 0.0, 0.0]" + text[text.index("\n", start):])
    with pytest.raises(RoboCalError, match=r"field 'cam0.intrinsics': not a camera matrix: the focal lengths"):
        read_any_stereo(chain)
    bare = ff.opencv_file(rig, tmp_path / "bare.yml", rectification=False)
    text = bare.read_text()
    start = text.index("data:", text.index("K1:"))
    bare.write_text(text[:start] + "data: [ 0., 0., 0., 0., 0., 0., 0., 0., 0. ]\n" + text[text.index("D1:"):])
    with pytest.raises(RoboCalError, match=r"field 'K1': not a camera matrix"):
        read_any_stereo(bare)
    left, right = ff.ros_pair(rig, tmp_path)
    text = right.read_text()
    start = text.index("projection_matrix:")
    right.write_text(text[:start] + "projection_matrix:\n  rows: 3\n  cols: 4\n  data: [1.0, 1.0, 0.0, -0.1, 1.0, 1.0, "
                     "0.0, 0.0, 0.0, 0.0, 1.0, 0.0]\n")
    with pytest.raises(RoboCalError, match=r"right.yaml: field 'projection_matrix': not a projection matrix"):
        read_any_stereo([left, right])


# -- other tools' layouts of the same numbers ------------------------------------------------------

def _imu_chain(rig, path: Path, key: str, header: str = "") -> Path:
    """A camchain holding no T_cn_cnm1 but each camera's pose against an IMU (metres): Kalibr's
    T_cam_imu (IMU → camera) or OpenVINS' T_imu_cam (camera → IMU), with an IMU placed at random."""
    import yaml
    from scipy.spatial.transform import Rotation

    data = yaml.safe_load(ff.kalibr_camchain(rig, path).read_text())
    cam1_cam0 = np.array(data["cam1"].pop("T_cn_cnm1"))
    imu_cam0 = np.eye(4)                                         # X_imu = imu_cam0 · X_cam0
    imu_cam0[:3, :3] = Rotation.from_rotvec([0.3, -1.2, 0.4]).as_matrix()
    imu_cam0[:3, 3] = [0.031, -0.012, 0.087]
    imu_cam1 = imu_cam0 @ np.linalg.inv(cam1_cam0)
    for name, T in (("cam0", imu_cam0), ("cam1", imu_cam1)):
        data[name][key] = (T if key == "T_imu_cam" else np.linalg.inv(T)).tolist()
    path.write_text(header + yaml.safe_dump(data))
    return path


@pytest.mark.parametrize("key, header, kind", [
    ("T_imu_cam", "%YAML:1.0\n", "Kalibr/OpenVINS IMU-camera chain"),       # OpenVINS kalibr_imucam_chain.yaml
    ("T_cam_imu", "", "Kalibr/OpenVINS IMU-camera chain"),                  # Kalibr camchain-imucam without T_cn_cnm1
])
def test_a_camchain_through_the_imu_is_composed_exactly(tmp_path, rig, key, header, kind):
    imported = read_any_stereo(_imu_chain(rig, tmp_path / "chain.yaml", key, header))
    assert imported.kind == kind and any(key in n for n in imported.notes)
    assert_same_pixels(imported, rig, tol=1e-6)
    assert imported.file.baseline_mm == pytest.approx(rig.baseline, rel=1e-9)


def test_a_kalibr_camchain_with_opencvs_yaml_header_and_a_byte_order_mark(tmp_path, rig):
    path = ff.kalibr_camchain(rig, tmp_path / "camchain.yaml")
    path.write_bytes(b"\xef\xbb\xbf%YAML:1.0\n" + path.read_bytes())
    assert_same_pixels(read_any_stereo(path), rig)


def test_a_camchain_without_the_pose_of_cam1_names_what_to_give(tmp_path, rig):
    path = ff.kalibr_camchain(rig, tmp_path / "camchain.yaml")
    path.write_text("\n".join(ln for ln in path.read_text().splitlines() if "T_cn_cnm1" not in ln
                              and not ln.startswith("  - [")) + "\n")
    with pytest.raises(RoboCalError, match="T_cn_cnm1, or T_cam_imu / T_imu_cam on both cameras") as err:
        read_any_stereo(path)
    assert err.value.field == "cam1.T_cn_cnm1"


def test_an_opencv_style_yaml_of_another_layout_says_so(tmp_path):
    path = tmp_path / "other.yaml"
    path.write_text("%YAML:1.0\ncam0:\n  intrinsics: !!opencv-matrix\n    rows: 1\n  bad: [1, 2\n")
    with pytest.raises(RoboCalError) as err:
        read_any_stereo(path)
    assert str(path) in err.value.message and "\n" not in err.value.message
    assert "OpenCV" in err.value.message


def test_plain_lists_and_a_byte_order_mark_as_cv2_filestorage_reads_them(tmp_path, rig):
    import cv2
    path = ff.opencv_file(rig, tmp_path / "stereo.yml", rectification=False)
    fs = cv2.FileStorage(str(path), cv2.FILE_STORAGE_READ)
    T = fs.getNode("T").mat().ravel()
    fs.release()
    text = path.read_text()
    start = text.index("T: !!opencv-matrix")
    end = text.index("]", start) + 1
    listed = text[:start] + "T: [ " + ", ".join(repr(float(v)) for v in T) + " ]" + text[end:]
    path.write_text(listed)
    fs = cv2.FileStorage(str(path), cv2.FILE_STORAGE_READ)             # OpenCV reads the list as T
    assert fs.getNode("T").isSeq() and [fs.getNode("T").at(i).real() for i in range(3)] == T.tolist()
    fs.release()
    assert_same_pixels(read_any_stereo(path), rig)
    bom = tmp_path / "bom.yml"
    bom.write_bytes(b"\xef\xbb\xbf" + path.read_bytes())
    assert_same_pixels(read_any_stereo(bom), rig)


def test_intrinsics_with_k1_k2_are_paired_with_their_extrinsics(tmp_path, rig):
    ff.stereo_calib_pair(rig, tmp_path)
    intr = tmp_path / "intrinsics.yml"
    intr.write_text(intr.read_text().replace("M1:", "K1:").replace("M2:", "K2:"))
    for given in (intr, tmp_path / "extrinsics.yml", tmp_path):
        imported = read_any_stereo(given, image_size=rig.left.size)
        assert imported.kind == "OpenCV stereo_calib intrinsics + extrinsics"
        assert_same_pixels(imported, rig)


def test_ros_pair_with_a_vertical_baseline_is_read_and_refused_for_location(tmp_path, rig, capsys):
    """Cameras one above the other: P2's translation is in its second row (Ty). The pair is read
    exactly (pose from the rectification and projection matrices); the marker location, which
    searches along rows, refuses it in one line naming the files and what to do."""
    from core.stereo.rig import StereoRig

    below = StereoRig(rig.left, rig.right, rig.R, [rig.T[1], -rig.baseline, rig.T[2]])    # right camera below
    left, right = ff.ros_pair(below, tmp_path)
    P2 = ff.rectify(below)[3]
    assert abs(P2[1, 3]) > 0 and P2[0, 3] == 0                       # what OpenCV writes for a vertical rig
    imported = read_any_stereo([left, right])
    assert_same_pixels(imported, below)
    np.testing.assert_allclose(imported.file.T, below.T, rtol=0, atol=1e-9)
    np.testing.assert_allclose(imported.file.R, below.R, rtol=0, atol=1e-12)
    with pytest.raises(RoboCalError, match=r"the cameras are one above the other \(vertical stereo\).*"
                                           r"Mount the cameras side by side") as err:
        load_rectification(tmp_path)
    assert str(err.value).startswith(f"{tmp_path}: ") and "\n" not in str(err.value)
    out = tmp_path / "stereo.yaml"
    assert main(["stereo-import", str(left), str(right), "--out", str(out)]) == 0
    assert "the marker location will refuse this calibration: the cameras are one above the other" in \
        capsys.readouterr().out
    np.testing.assert_allclose(read_any_stereo(out).file.T, below.T, rtol=0, atol=1e-9)
