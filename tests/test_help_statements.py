"""What the help pages and guides state about RoboCal's computations, checked against the code.

Each test reads a statement from the text (resources/help/*.html, docs/*.md, docstrings) and
computes the same thing with RoboCal's own functions and constants: the triangulation of the
chapter's (23)–(25) with its sign slip, the camera model's number, the weighted step and
covariance of the identification, the two condition numbers, the check's choice among the
candidate changes, the marker's verification and the epipolar error figure, Hayati's β.
"""
from __future__ import annotations

import html
import json
import re
from pathlib import Path

import numpy as np
import pytest

from core.resources import resource_path

ROOT = Path(__file__).resolve().parents[1]
HELP = Path(resource_path("help"))
TABLE = json.loads((HELP / "chapter_equations.json").read_text(encoding="utf-8"))["equations"]
ROW = re.compile(r"<tr>(.*?)</tr>", re.S)


def plain(page: str) -> str:
    """The help page's words, tags removed (sub/superscripts joined), white space collapsed."""
    return " ".join(re.sub(r"<[^>]+>", "", html.unescape((HELP / page).read_text(encoding="utf-8"))).split())


def numbered(page: str, n: int) -> str:
    """The text of the page's equation row numbered (n)."""
    text = html.unescape((HELP / page).read_text(encoding="utf-8"))
    rows = [" ".join(re.sub(r"<[^>]+>", "", r.replace("</td>", " ")).split()) for r in ROW.findall(text)
            if f">({n})<" in r]
    assert rows, f"{page}: no row numbered ({n})"
    return " ".join(rows)


# -- 1. triangulation (23)–(25) ---------------------------------------------------------------
def test_the_sign_slip_is_in_25_and_the_page_uses_two_symbols_for_two_origins():
    assert "sign slip" not in TABLE["23"] and "sign slip" in TABLE["25"]
    assert "−B(u₁ + u₂)/(2d)" in TABLE["25"] and "z_w is (24)" in TABLE["25"]
    assert numbered("marker.html", 23) == "d = u1 − u2 = f·b / zw (23)"
    row25 = numbered("marker.html", 25)
    assert row25.startswith("xw = b·(u1 + u2) / (2d)") and "yw = b·v / d" in row25 and "Z" not in row25
    text = plain("marker.html")
    assert "The chapter prints (25) as xw = −b·(u1 + u2) / (2d), a sign slip" in text
    assert "(23) is printed with a sign slip" not in text
    assert "Before that rotation X = xw + b/2, Y = yw, Z = zw" in text


def test_rectified_triangulation_agrees_with_25_with_the_plus_sign():
    """RoboCal's rectified triangulation of u1, u2 of a point given midway along the baseline
    is +b(u1 + u2)/(2d) (shifted by b/2 to the left camera), not the printed −."""
    from core.marker.triangulation import triangulate_rectified
    f, cx, cy, b = 1400.0, 640.0, 512.0, 130.0
    P1 = np.array([[f, 0, cx, 0], [0, f, cy, 0], [0, 0, 1, 0]])
    P2 = np.array([[f, 0, cx, -f * b], [0, f, cy, 0], [0, 0, 1, 0]])
    for xw, yw, zw in [(40.0, -25.0, 700.0), (-90.0, 60.0, 950.0)]:
        u1, u2, v = f * (xw + b / 2) / zw, f * (xw - b / 2) / zw, f * yw / zw       # from the principal point
        d = u1 - u2
        assert d == pytest.approx(f * b / zw)                                         # (23)
        point = triangulate_rectified(u1 + cx, v + cy, d, P1, P2, np.eye(3)).point
        np.testing.assert_allclose(point, [xw + b / 2, yw, f * b / d], atol=1e-9)     # (24), left origin
        plus, minus = b * (u1 + u2) / (2 * d), -b * (u1 + u2) / (2 * d)
        assert plus == pytest.approx(point[0] - b / 2) and minus != pytest.approx(point[0] - b / 2)
        assert b * v / d == pytest.approx(point[1])


# -- 2. the chapter's (11) ---------------------------------------------------------------------
def test_11_is_the_camera_model_p_equals_MP():
    assert "p = K·[R T]·P = M·P" in TABLE["11"]
    assert numbered("stereo.html", 11) == "p = K · [R T] · P = M · P (11)"
    assert "x = X / Z" not in numbered("stereo.html", 11)


# -- 3. the identification's weighted step and covariance ------------------------------------
@pytest.fixture(scope="module")
def lab_fit(built_lab):
    from core.identification.solver import identify
    from core.virtual_lab.synthetic import simulate_measurements
    lab = built_lab(seed=0)
    meas = simulate_measurements(lab.true_robot, 30, sigma_mm=0.05, targets=[lab.target], with_sigma=True,
                                 rng=np.random.default_rng(4))
    # each point its own σ: the noise is 0.05 mm, the file claims 0.025 on half the points
    meas.sigma[::2] *= 0.5
    return lab, meas, identify(lab.nominal_robot, meas)


def test_covariance_and_sigma_hat_are_the_weighted_ones_the_page_shows(lab_fit):
    from core.kinematics.jacobian import calibration_jacobian, predict_points
    lab, meas, result = lab_fit
    text = plain("identification.html")
    assert "Δg = (ΦTWΦ + λ · D²)−1 ΦTW ΔX" in text
    assert "cov(ĝ) ≈ σ̂² (ΦTWΦ)−1, σ̂² = ΔXTWΔX / (3L − p)" in text
    assert "σ̂² = ‖ΔX‖² / (3L − p)" not in text and "running maximum" in text
    assert "σ̂ has no unit" in text and result.weighted and "×" in result.sigma_hat_text
    free = result.identifiability.free
    assert [p.name for p in free] == result.estimated
    w = (1.0 / meas.sigma ** 2).reshape(-1)
    phi = calibration_jacobian(result.model, meas.Q, meas.target, free)
    dx = (meas.xyz - predict_points(result.model, meas.Q, meas.target)).reshape(-1)
    dof = 3 * meas.n_points - len(free)
    sigma_hat = float(np.sqrt(dx @ (w * dx) / dof))
    assert result.sigma_hat == pytest.approx(sigma_hat, rel=1e-6)
    cov = sigma_hat ** 2 * np.linalg.inv(phi.T @ (w[:, None] * phi))
    np.testing.assert_allclose(np.sqrt(np.diag(result.covariance)), np.sqrt(np.diag(cov)), rtol=1e-4)
    # the unweighted formula of the old page gives mm, not this unitless figure
    assert float(np.sqrt(dx @ dx / dof)) < 0.5 * sigma_hat


# -- 4. the two condition numbers --------------------------------------------------------------
def test_the_fit_kappa_and_the_pose_set_kappa_are_named_apart(lab_fit):
    from core.kinematics.identifiability import observability_indices
    from core.kinematics.jacobian import calibration_jacobian
    from core.poses.selection import scaled_blocks
    lab, meas, result = lab_fit
    w = np.sqrt(1.0 / meas.sigma ** 2).reshape(-1)
    phi_w = w[:, None] * calibration_jacobian(result.model, meas.Q, meas.target, result.identifiability.free)
    kappa_fit = observability_indices(phi_w).condition_number                   # own column norms
    assert result.condition_number == pytest.approx(kappa_fit, rel=1e-6)
    A, names, scales, _ = scaled_blocks(lab.nominal_robot, meas.Q, [lab.target])
    s = np.linalg.svd(A.reshape(-1, len(names)), compute_uv=False)
    kappa_poses = float(s[0] / s[-1])
    assert 100 < kappa_fit < 1000 and 10 < kappa_poses < 30 and kappa_fit > 5 * kappa_poses    # 197 and 24 here
    ident, poses = plain("identification.html"), plain("poses.html")
    for text in (ident, poses):
        assert "κ of the fit" in text and "κ of the pose set" in text
        assert "a few hundred" in text and "ten to thirty" in text
    assert "divide every column by its own norm" in ident and "per radian times the robot's reach" in ident
    assert "fixed column scales" in ident and "divided by its own norm" in poses


def test_fixing_a_needed_parameter_lowers_kappa_and_raises_the_error(lab_fit):
    """"κ also falls when you fix parameters … a lower κ with a higher RMS after calibration
    means the fixed parameter was needed"."""
    from core.identification.solver import identify
    lab, meas, result = lab_fit
    fixed = identify(lab.nominal_robot, meas, fixed=["J2.a"])
    assert fixed.condition_number < result.condition_number
    assert fixed.after.rms_mm > 3 * result.after.rms_mm
    assert "a lower κ with a higher RMS after calibration means the fixed parameter was needed" in \
        plain("identification.html")


# -- 5. the check's choice among the candidate changes ------------------------------------------
def test_the_check_takes_the_lowest_aic_among_the_sets_the_f_test_keeps():
    from core.monitoring.diagnosis import NONE, SEVERAL, TOOL
    from tests.core.monitoring.test_diagnosis import checked
    text = plain("check.html")
    assert "keeps the smallest change" not in text
    assert "the one with the lowest Akaike criterion, AIC = the weighted residual sum of squares + 2 ×" in text
    assert "monitored in real-time based on marker's position" in text
    sizes = {}
    for change in ("tool:1.5", "link2:1"):
        c, result, diag = checked(change)
        c.reset()
        sizes[change] = np.linalg.norm(result.residuals.reshape(-1, 3), axis=1)
        kept = [f for f in diag.fits if f.nested_probability >= diag.alpha and f.kind not in (NONE, SEVERAL)]
        if change == "tool:1.5":
            assert diag.explained and diag.chosen is min(kept, key=lambda f: f.aic) and diag.kind == TOOL
            assert len({f.p for f in diag.fits}) > 2           # sets of different sizes compete
        else:
            assert not diag.explained and diag.full_calibration
    # both changes give about the same error at every pose: the sizes alone do not tell them apart
    for change, lo, hi in (("tool:1.5", 1.4, 1.7), ("link2:1", 0.9, 1.2)):
        assert lo <= sizes[change].min() and sizes[change].max() <= hi, (change, sizes[change])
        assert sizes[change].max() / sizes[change].min() < 1.3
    assert "1.4–1.7 mm and 0.9–1.2 mm" in text and "the marker or the base moved" not in text


# -- 7. the epipolar error figure, Hayati's β in the model's docstring ------------------------
def test_both_guides_give_the_same_epipolar_figure_and_real_cameras_meet_it():
    from core.stereo.board import Board
    from core.stereo.calibration import calibrate_stereo
    from core.stereo.screening import detect_pairs
    from tests.core.stereo_synth import REAL_DATA, real_pairs
    words = "below about 0.3 px RMS"
    assert words in plain("stereo.html")
    assert words in " ".join((ROOT / "docs" / "user-guide.md").read_text(encoding="utf-8").split())
    assert "well below 1 px" not in plain("stereo.html")
    if not REAL_DATA.is_dir():
        pytest.skip(f"real checkerboard pairs not found at {REAL_DATA}")
    r = calibrate_stereo(detect_pairs(real_pairs(), Board(9, 6, 24.0)))
    assert 0.1 < r.epipolar_rms < 0.3                                   # "about 0.2 px with real cameras"


def test_hayati_beta_replaces_the_d_of_its_own_joint():
    from core.kinematics.identifiability import HAYATI
    from core.identification.solver import identify
    from core.robot.file import read_robot
    from core.robot.model import RobotModel
    from core.virtual_lab.synthetic import simulate_measurements
    doc = " ".join(RobotModel.parallel_axis_joints.__doc__.split())
    assert "replaces its own ill-conditioned d" in doc and "d_(i+1)" not in doc
    robot = read_robot(resource_path("robots", "educational_6r.json"))
    (i,) = robot.parallel_axis_joints()
    meas = simulate_measurements(robot, 20, rng=np.random.default_rng(0))
    status = {e.name: e.status for e in identify(robot, meas).identifiability.excluded}
    assert status.get(f"J{i + 1}.d") == HAYATI and f"J{i + 2}.d" not in status
