"""Standard deviations of the stereo calibration's parameters, including R, T and the
baseline, from the Jacobian of the joint fit at the solution: Σ = σ̂²(JᵀJ)⁻¹,
σ̂² = SSR / (m − n). (`stereoCalibrateExtended` gives no standard deviations; the per-camera
ones of `calibrateCameraExtended` are kept in `mono_left`/`mono_right` for comparison, and
used for the intrinsics when the stereo fit keeps them fixed.)

Units: px for the intrinsics, mm for T and the baseline, degrees for the rotation vector.

The covariance of the parameters a triangulated point depends on most (TRIANGULATION_PARAMETERS:
both cameras' fx, fy, cx, cy, the rotation vector and T) is kept with their correlations, which
matter: the principal points and the rotation, or the focal lengths and T, move together in
the fit, and taking them as independent overstates a point's uncertainty about tenfold
(core/stereo/point_uncertainty.py propagates it to a point).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np

from core.stereo.file import TRIANGULATION_PARAMETERS
from core.stereo.fit import CalibrationOptions, StereoFit

DIST_NAMES = ("k1", "k2", "p1", "p2", "k3", "k4", "k5", "k6")


@dataclass
class CameraParameterRow:
    """A row of the stereo parameter table: value ± std (std 0 and fixed=True for fixed ones)."""

    group: str        # "left", "right" or "stereo"
    name: str         # "fx", "k1", "baseline", "rx", ...
    value: float
    std: float
    unit: str
    fixed: bool = False

    def text(self) -> str:
        if self.fixed:
            return f"{self.value:.6g} {self.unit} (fixed)".strip()
        return f"{self.value:.6g} ± {self.std:.2g} {self.unit}".strip()


def _intrinsic_map(K: np.ndarray, options: CalibrationOptions) -> tuple[np.ndarray, list[str]]:
    """Matrix M with d(fx fy cx cy d...)/d(free parameters), and the free parameters' names."""
    n = 4 + options.n_dist
    cols, names = [], []
    if options.fix_aspect:
        col = np.zeros(n)
        col[0] = K[0, 0] / K[1, 1]
        col[1] = 1.0
        cols.append(col)
        names.append("f")
    else:
        for i, name in ((0, "fx"), (1, "fy")):
            col = np.zeros(n)
            col[i] = 1.0
            cols.append(col)
            names.append(name)
    if not options.fix_principal:
        for i, name in ((2, "cx"), (3, "cy")):
            col = np.zeros(n)
            col[i] = 1.0
            cols.append(col)
            names.append(name)
    for i in options.free_distortion():
        col = np.zeros(n)
        col[4 + i] = 1.0
        cols.append(col)
        names.append(DIST_NAMES[i])
    return np.array(cols).T, names


def parameter_uncertainty(obj: np.ndarray, fit: StereoFit, options: CalibrationOptions
                          ) -> tuple[dict[str, float], list[CameraParameterRow], np.ndarray]:
    """Standard deviations ({name_group: std}), the parameter table of a joint fit (`obj`: the
    board's (N, 3) corners, mm) and the covariance of TRIANGULATION_PARAMETERS (14 x 14; px,
    deg, mm; intrinsics kept fixed by the stereo fit: their single-camera variances, uncorrelated)."""
    pair = fit.file
    res_l, res_r = fit.residuals_left, fit.residuals_right
    V, N = res_l.shape[:2]
    M1, names1 = _intrinsic_map(pair.K1, options)
    M2, names2 = _intrinsic_map(pair.K2, options)
    p1, p2 = M1.shape[1], M2.shape[1]
    refine = options.refine_intrinsics
    n_intr = (p1 + p2) if refine else 0
    n = n_intr + 6 + 6 * V
    m = 2 * 2 * N * V
    J = np.zeros((m, n))
    rvec_rel = cv2.Rodrigues(pair.R)[0]
    rel0 = n_intr
    row = 0
    for v in range(V):
        r, t = fit.rvecs[v].reshape(3, 1), fit.tvecs[v].reshape(3, 1)
        view0 = n_intr + 6 + 6 * v
        _, Jl = cv2.projectPoints(obj, r, t, pair.K1, pair.D1)
        J[row:row + 2 * N, view0:view0 + 6] = Jl[:, :6]
        if refine:
            J[row:row + 2 * N, 0:p1] = Jl[:, 6:] @ M1
        row += 2 * N
        r3, t3, dr3dr1, dr3dt1, dr3dr2, dr3dt2, dt3dr1, dt3dt1, dt3dr2, dt3dt2 = cv2.composeRT(
            r, t, rvec_rel, pair.T.reshape(3, 1))
        _, Jr = cv2.projectPoints(obj, r3, t3, pair.K2, pair.D2)
        Jpose = Jr[:, :6]
        d_view = np.block([[dr3dr1, dr3dt1], [dt3dr1, dt3dt1]])
        d_rel = np.block([[dr3dr2, dr3dt2], [dt3dr2, dt3dt2]])
        J[row:row + 2 * N, view0:view0 + 6] = Jpose @ d_view
        J[row:row + 2 * N, rel0:rel0 + 6] = Jpose @ d_rel
        if refine:
            J[row:row + 2 * N, p1:p1 + p2] = Jr[:, 6:] @ M2
        row += 2 * N
    ssr = float((res_l ** 2).sum() + (res_r ** 2).sum())
    dof = max(m - n, 1)
    sigma2 = ssr / dof
    JtJ = J.T @ J
    try:
        cov = sigma2 * np.linalg.inv(JtJ)
    except np.linalg.LinAlgError:
        cov = sigma2 * np.linalg.pinv(JtJ)
    sd = np.sqrt(np.clip(np.diag(cov), 0.0, None))

    std: dict[str, float] = {}
    rows: list[CameraParameterRow] = []
    for group, K, D, M, names, off in (("left", pair.K1, pair.D1, M1, names1, 0),
                                        ("right", pair.K2, pair.D2, M2, names2, p1)):
        full_cov = M @ cov[off:off + M.shape[1], off:off + M.shape[1]] @ M.T if refine \
            else np.zeros((M.shape[0], M.shape[0]))
        full_sd = np.sqrt(np.clip(np.diag(full_cov), 0.0, None))
        values = [K[0, 0], K[1, 1], K[0, 2], K[1, 2], *D]
        all_names = ["fx", "fy", "cx", "cy", *DIST_NAMES[:len(D)]]
        free = set(names) | ({"fx", "fy"} if "f" in names else set())
        for i, (name, value) in enumerate(zip(all_names, values)):
            fixed = name not in free or not refine
            unit = "px" if i < 4 else ""
            s = 0.0 if (name not in free) else float(full_sd[i])
            if not refine and name in free:
                mono = fit.mono_left if group == "left" else fit.mono_right
                s = float(mono.std_intrinsics[i]) if i < mono.std_intrinsics.size else 0.0
                fixed = False
            std[f"{name}_{group}"] = s
            rows.append(CameraParameterRow(group, name, float(value), s, unit, fixed))
    rvec = cv2.Rodrigues(pair.R)[0].ravel()
    for i, name in enumerate(("rx", "ry", "rz")):
        s = math.degrees(float(sd[rel0 + i]))
        std[name] = s
        rows.append(CameraParameterRow("stereo", name, math.degrees(float(rvec[i])), s, "deg"))
    for i, name in enumerate(("tx", "ty", "tz")):
        s = float(sd[rel0 + 3 + i])
        std[name] = s
        rows.append(CameraParameterRow("stereo", name, float(pair.T[i]), s, "mm"))
    b = float(np.linalg.norm(pair.T))
    g = pair.T / b if b > 0 else np.zeros(3)
    cov_t = cov[rel0 + 3:rel0 + 6, rel0 + 3:rel0 + 6]
    s_b = float(math.sqrt(max(g @ cov_t @ g, 0.0)))
    std["baseline"] = s_b
    rows.append(CameraParameterRow("stereo", "baseline", b, s_b, "mm"))
    return std, rows, _triangulation_covariance(cov, M1, M2, p1, refine, rel0, std)


def _triangulation_covariance(cov, M1, M2, p1: int, refine: bool, rel0: int, std: dict[str, float]) -> np.ndarray:
    """The joint fit's covariance mapped onto TRIANGULATION_PARAMETERS (rotation in degrees)."""
    G = np.zeros((len(TRIANGULATION_PARAMETERS), cov.shape[0]))
    if refine:
        G[0:4, 0:p1] = M1[:4]
        G[4:8, p1:p1 + M2.shape[1]] = M2[:4]
    G[8:11, rel0:rel0 + 3] = np.eye(3) * math.degrees(1.0)
    G[11:14, rel0 + 3:rel0 + 6] = np.eye(3)
    out = G @ cov @ G.T
    if not refine:                     # fixed in the stereo fit: the single-camera fits' variances
        for i, name in enumerate(TRIANGULATION_PARAMETERS[:8]):
            out[i, i] = std.get(name, 0.0) ** 2
    return out
