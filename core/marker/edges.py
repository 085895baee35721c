"""The precise reference point: Canny edges of the outer square, sub-pixel lines, diagonals.

Given where the outer black square roughly is (the outline predicted by the SIFT homography,
or by tracking), `fit_outline`:

1. runs Canny on the region of interest only (the predicted outline plus a margin);
2. attributes each edge pixel to one of the four sides of the predicted outline: close to the
   side, away from the corners, gradient across the side and pointing outwards (the square
   is dark, the plate border around it white);
3. fits a line to each side's edge pixels (cv2.fitLine, Huber), in *ideal* pixels (lens
   distortion removed and, for a stereo pair, rectified: see `PixelMap`), where the image of
   a straight edge is straight;
4. refines each line to sub-pixel accuracy with an edge model fitted to every pixel of a band
   across the side (grey level = A(t) + B(t)·Φ((n·p − ρ)/s): a blurred step whose dark and
   bright levels may vary linearly along the side; Gauss–Newton with Huber weights, so a
   little clutter on a side does not pull it). The band is symmetric about the edge and
   limited by the marker's black band inside and the white border outside (measured at
   training), so that no other edge enters it; near the corners it is cut off, and so is any
   stretch of the side without Canny pixels (covered, e.g. a cable over a corner: its shade and
   its own edges would bend the line), with a margin;
5. intersects adjacent lines (corners) and the two diagonals of the quadrilateral: the
   reference point, the image of the square's centre, exact under perspective;
6. propagates the line-fit covariance (from the edge-model residuals) to the reference point.

All of it runs on a region of a few hundred pixels per side, a few milliseconds per image.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import cv2
import numpy as np
from scipy.special import ndtr

from core.camera import PixelMap
from core.marker.geometry import (bounding_box, corners_from_lines, diagonal_intersection,
                                  line_through, side_lengths)

_SQRT_2PI = np.sqrt(2.0 * np.pi)


@dataclass
class EdgeOptions:
    """Tuning of the reference-point stage (defaults suit 0.5–4 px/mm views of the marker)."""

    attribution_tolerance: float = 4.0     # px: edge pixel to predicted side (plus 2 % of the side)
    max_gradient_angle: float = 30.0       # deg between the edge gradient and the side normal
    half_band: float = 3.5                 # px: edge-model band, each side of the edge (at most)
    min_half_band: float = 1.2             # px: below this the side is not fitted
    corner_gap: float = 2.5                # px cut off near the corners, beyond the band
    min_side_coverage: float = 0.2         # fraction of a side whose edge must be seen (a covered corner hides some)
    max_edge_gap: float = 6.0              # px along a side without Canny pixels: the edge is hidden there
    max_corner_shift: float = 0.12         # fitted corner vs predicted, fraction of the mean side
    min_corner_shift_px: float = 4.0
    iterations: int = 12
    # px, added in quadrature to the reference point's sigma from the edge-fit residuals: the
    # systematic edge errors the residuals do not show (edge-model mismatch, image formation).
    # 0.0014 px makes the predicted 3D uncertainty match the errors on the virtual lab (bench
    # `marker`: 0.99 of it on the tuning views); real lenses and sensors may need more.
    sigma_floor_px: float = 0.0014


@dataclass
class SideFit:
    """One side of the outer square."""

    line: np.ndarray               # (3,) nx, ny, rho in ideal px (n outward)
    line_cov: np.ndarray           # (2, 2) covariance of (phi, rho)
    blur: float                    # px, fitted edge width (Gaussian sigma)
    contrast: float                # grey levels, bright − dark at the side's centre
    residual_rms: float            # grey levels
    n_pixels: int                  # pixels used by the edge model
    n_edge_pixels: int             # Canny pixels attributed to the side
    canny_line: np.ndarray         # (3,) the initial line from the Canny pixels (ideal px)


@dataclass
class OutlineFit:
    """The outer square found to sub-pixel accuracy (what the GUI draws for the Canny stage).

    Raw pixels are those of the image given; ideal pixels those of `PixelMap` (undistorted,
    possibly rectified). `ok` False means `reason` says why no point is given."""

    ok: bool
    reason: str = ""
    roi: tuple[int, int, int, int] = (0, 0, 0, 0)            # x0, y0, x1, y1 (exclusive), raw px
    predicted_outline: np.ndarray | None = None              # (4, 2) raw px
    edge_pixels: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))   # (E, 2) Canny, raw px
    edge_side: np.ndarray = field(default_factory=lambda: np.zeros(0, int))     # (E,) side 0..3 or -1
    sides: list[SideFit] = field(default_factory=list)
    lines: np.ndarray | None = None                          # (4, 3) ideal px
    corners_ideal: np.ndarray | None = None                  # (4, 2)
    corners: np.ndarray | None = None                        # (4, 2) raw px
    reference_ideal: np.ndarray | None = None                # (2,)
    reference: np.ndarray | None = None                      # (2,) raw px
    reference_cov: np.ndarray | None = None                  # (2, 2) ideal px², from the line fits
    outline_polyline: np.ndarray | None = None               # (4 * 16, 2) raw px along the fitted sides

    @property
    def sigma_px(self) -> float:
        """RMS standard deviation of the reference point per axis (ideal px)."""
        if self.reference_cov is None:
            return float("nan")
        return float(np.sqrt(np.trace(self.reference_cov) / 2.0))


def _fail(reason: str, **kw) -> OutlineFit:
    return OutlineFit(False, reason, **kw)


def canny_thresholds(gray: np.ndarray) -> tuple[float, float]:
    """Canny thresholds from the strongest gradients of the region (Sobel 3x3 units, L2)."""
    gx = cv2.Sobel(gray, cv2.CV_32F, 1, 0, ksize=3)
    gy = cv2.Sobel(gray, cv2.CV_32F, 0, 1, ksize=3)
    mag = cv2.magnitude(gx, gy)
    top = float(np.percentile(mag, 99.0)) if mag.size else 0.0
    high = max(0.3 * top, 40.0)
    return 0.5 * high, high


def _side_frame(line: np.ndarray, c0: np.ndarray, c1: np.ndarray):
    n = line[:2]
    tau = np.array([-n[1], n[0]])           # n = (tau_y, -tau_x)  <=>  tau = (-n_y, n_x)
    t0, t1 = float(tau @ c0), float(tau @ c1)
    return n, tau, t0, t1


def _edge_model_fit(values: np.ndarray, pts: np.ndarray, line: np.ndarray, t_mid: float, t_half: float,
                    blur0: float, iterations: int, start: np.ndarray | None = None):
    """Gauss–Newton (Levenberg–Marquardt, Huber IRLS) of I = A(t) + B(t)·Φ((n·p − ρ)/s) over
    band pixels, n = (cos φ, sin φ), A and B linear along the side (t ∈ [−1, 1]).

    Returns (line (3,), cov of (φ, ρ) 2x2, blur s, contrast B, residual RMS, parameters) or None."""
    tau0 = np.array([-line[1], line[0]])
    tt = (pts @ tau0 - t_mid) / max(t_half, 1e-6)
    px, py = pts[:, 0], pts[:, 1]
    if start is None:
        d = pts @ line[:2] - line[2]
        inside, outside = values[d < -1.0], values[d > 1.0]
        if inside.size < 3 or outside.size < 3:
            return None
        a0 = float(np.median(inside))
        b0 = float(np.median(outside)) - a0
        if b0 <= 0:
            return None
        x = np.array([np.arctan2(line[1], line[0]), line[2], blur0, a0, 0.0, b0, 0.0])
    else:
        x = np.array(start, dtype=float)
        x[0], x[1] = np.arctan2(line[1], line[0]), line[2]
    ones = np.ones_like(values)

    def evaluate(p):
        c, sn = np.cos(p[0]), np.sin(p[0])
        z = (px * c + py * sn - p[1]) / p[2]
        Phi = ndtr(z)
        B = p[5] + p[6] * tt
        r = p[3] + p[4] * tt + B * Phi - values
        return r, z, Phi, B, c, sn

    def jacobian(p, z, Phi, B, c, sn):
        g = B * np.exp(-0.5 * z * z) / (_SQRT_2PI * p[2])
        return np.column_stack([g * (py * c - px * sn), -g, -g * z, ones, tt, Phi, tt * Phi])

    def weights(r):
        k = 1.5 * (1.4826 * float(np.median(np.abs(r))) + 1e-6)
        ar = np.abs(r)
        return np.where(ar <= k, 1.0, k / np.maximum(ar, 1e-12))

    r, z, Phi, B, c, sn = evaluate(x)
    lam = 1e-3
    for _ in range(iterations):
        J = jacobian(x, z, Phi, B, c, sn)
        w = weights(r)
        JW = J * w[:, None]
        A = JW.T @ J
        b = JW.T @ r
        cost = float(np.sum(w * r * r))
        diag = np.diag(np.diag(A) + 1e-9)
        accepted = False
        for _ in range(6):
            try:
                step = np.linalg.solve(A + lam * diag, -b)
            except np.linalg.LinAlgError:
                return None
            xn = x + step
            xn[2] = max(xn[2], 0.05)
            rn, zn, Phin, Bn, cn_, snn = evaluate(xn)
            if float(np.sum(w * rn * rn)) <= cost:
                x, r, z, Phi, B, c, sn = xn, rn, zn, Phin, Bn, cn_, snn
                lam = max(lam / 5.0, 1e-7)
                accepted = True
                break
            lam *= 10.0
        if not accepted or (abs(step[0]) < 2e-6 and abs(step[1]) < 2e-4):
            break
    J = jacobian(x, z, Phi, B, c, sn)
    w = weights(r)
    dof = max(values.size - 7, 1)
    s2 = float(np.sum(w * r * r)) / dof
    try:
        cov = s2 * np.linalg.inv((J * w[:, None]).T @ J)
    except np.linalg.LinAlgError:
        return None
    if not np.all(np.isfinite(cov)):
        return None
    return (np.array([c, sn, x[1]]), cov[:2, :2], float(x[2]), float(x[5]), float(np.sqrt(np.mean(r * r))), x)


def _along_visible_edge(t: np.ndarray, t_edge: np.ndarray, start: float, end: float, max_gap: float,
                        margin: float) -> np.ndarray:
    """Which band positions `t` (ideal px along the side) lie where the edge is seen: away from
    every stretch of [start, end] longer than `max_gap` with no Canny pixel (`t_edge`), by
    `margin` (an occluder's own edges and shade blur into the band there)."""
    keep = np.ones(t.shape, bool)
    te = np.sort(t_edge[(t_edge > start) & (t_edge < end)])
    stops = np.concatenate([[start], te, [end]])
    last = len(stops) - 2
    for i in np.nonzero(np.diff(stops) > max_gap)[0]:
        lo = -np.inf if i == 0 else stops[i] - margin
        hi = np.inf if i == last else stops[i + 1] + margin
        keep &= (t <= lo) | (t >= hi)
    return keep


def _reference_from_params(params: np.ndarray) -> np.ndarray:
    lines = np.column_stack([np.cos(params[0::2]), np.sin(params[0::2]), params[1::2]])
    return diagonal_intersection(corners_from_lines(lines))


def reference_covariance(lines: np.ndarray, line_covs: list[np.ndarray]) -> np.ndarray:
    """Covariance (2x2) of the diagonal intersection from the (phi, rho) covariance of each line."""
    params = np.empty(8)
    params[0::2] = np.arctan2(lines[:, 1], lines[:, 0])
    params[1::2] = lines[:, 2]
    J = np.empty((2, 8))
    for i in range(8):
        h = 1e-6 if i % 2 == 0 else 1e-4
        p1, p2 = params.copy(), params.copy()
        p1[i] += h
        p2[i] -= h
        J[:, i] = (_reference_from_params(p1) - _reference_from_params(p2)) / (2 * h)
    C = np.zeros((8, 8))
    for k in range(4):
        C[2 * k:2 * k + 2, 2 * k:2 * k + 2] = line_covs[k]
    return J @ C @ J.T


def fit_outline(image: np.ndarray, predicted: np.ndarray, pixel_map: PixelMap | None = None, *,
                inner_px=None, outer_px=None, options: EdgeOptions | None = None) -> OutlineFit:
    """Find the outer square near the `predicted` outline (4, 2 raw px, clockwise from top-left).

    `inner_px` / `outer_px` (4,) are the widths (raw px) of the clean dark band inside and of
    the bright border outside each side, as predicted from the trained marker; they bound the
    edge-model band so that no other edge enters it. `pixel_map` turns raw pixels into ideal
    ones (None: identity)."""
    opt = options or EdgeOptions()
    pm = pixel_map or PixelMap()
    img = image if image.ndim == 2 else cv2.cvtColor(image, cv2.COLOR_BGR2GRAY)
    h_img, w_img = img.shape
    predicted = np.asarray(predicted, dtype=float).reshape(4, 2)
    L_raw = side_lengths(predicted)
    inner = np.full(4, 1e9) if inner_px is None else np.asarray(inner_px, dtype=float)
    outer = np.full(4, 1e9) if outer_px is None else np.asarray(outer_px, dtype=float)
    pad = float(min(np.max(np.minimum(outer, 12.0)), 12.0)) + opt.attribution_tolerance + 3.0
    roi = bounding_box(predicted, pad, (w_img, h_img))
    x0, y0, x1, y1 = roi
    base = dict(roi=roi, predicted_outline=predicted)
    if x1 - x0 < 8 or y1 - y0 < 8:
        return _fail("the marker region is too small", **base)
    sub = img[y0:y1, x0:x1]
    low, high = canny_thresholds(sub)
    edges = cv2.Canny(sub, low, high, L2gradient=True)
    ey, ex = np.nonzero(edges)
    pts = np.column_stack([ex + x0, ey + y0]).astype(float)
    gx = cv2.Sobel(sub, cv2.CV_32F, 1, 0, ksize=3)[ey, ex]
    gy = cv2.Sobel(sub, cv2.CV_32F, 0, 1, ksize=3)[ey, ex]
    gnorm = np.hypot(gx, gy) + 1e-9
    labels = np.full(len(pts), -1, int)
    best = np.full(len(pts), np.inf)
    cos_max = np.cos(np.deg2rad(opt.max_gradient_angle))
    for k in range(4):
        c0, c1 = predicted[k], predicted[(k + 1) % 4]
        line = line_through(c0, c1)
        n, tau, t0, t1 = _side_frame(line, c0, c1)
        d = pts @ n - line[2]
        t = pts @ tau
        trim = min(0.1 * L_raw[k], 3.0 + opt.corner_gap)
        tol = opt.attribution_tolerance + 0.02 * L_raw[k]
        along = (gx * n[0] + gy * n[1]) / gnorm
        ok = (np.abs(d) <= tol) & (t >= t0 + trim) & (t <= t1 - trim) & (along >= cos_max)
        better = ok & (np.abs(d) < best)
        labels[better] = k
        best[better] = np.abs(d[better])
    base.update(edge_pixels=pts, edge_side=labels)

    ideal_pts = pm.to_ideal(pts) if len(pts) else pts
    pred_ideal = pm.to_ideal(predicted)
    lines0 = np.zeros((4, 3))
    n_edge = np.zeros(4, int)
    for k in range(4):
        sel = ideal_pts[labels == k]
        n_edge[k] = len(sel)
        need = max(5, int(opt.min_side_coverage * L_raw[k] * 0.8))
        if len(sel) < need:
            return _fail(f"the edge of side {k + 1} of the outer square was not found "
                         f"({len(sel)} edge pixels, {need} needed): hidden, blurred or outside the view", **base)
        vx, vy, px, py = cv2.fitLine(sel.astype(np.float32), cv2.DIST_HUBER, 0, 0.01, 0.01).ravel()
        nrm = np.array([vy, -vx], dtype=float)
        pl = line_through(pred_ideal[k], pred_ideal[(k + 1) % 4])
        if nrm @ pl[:2] < 0:
            nrm = -nrm
        lines0[k] = [nrm[0], nrm[1], float(nrm @ np.array([px, py], dtype=float))]
    try:
        corners0 = corners_from_lines(lines0)
    except np.linalg.LinAlgError:
        return _fail("the four edges do not form a quadrilateral", **base)

    # -- sub-pixel edge model per side ------------------------------------------------------
    scale = pm.jacobian_scale()
    sub_f = sub.astype(np.float32)
    lines = lines0.copy()
    fits: list[SideFit] = []
    # candidate raw pixels: the ROI grid near the raw image of each initial side
    yy, xx = np.mgrid[y0:y1, x0:x1]
    grid = np.column_stack([xx.ravel(), yy.ravel()]).astype(float)
    corners_raw0 = pm.to_raw(corners0)
    for k in range(4):
        hb_raw = min(opt.half_band, 0.8 * inner[k], 0.8 * outer[k])
        if hb_raw < opt.min_half_band:
            return _fail(f"side {k + 1}: the clean band along the edge is only {2 * hb_raw:.1f} px wide "
                         f"(the marker is seen too small or too oblique)", **base)
        c0r, c1r = corners_raw0[k], corners_raw0[(k + 1) % 4]
        lr = line_through(c0r, c1r)
        n_r, tau_r, t0r, t1r = _side_frame(lr, c0r, c1r)
        d = grid @ n_r - lr[2]
        t = grid @ tau_r
        cut = hb_raw + opt.corner_gap
        near = (np.abs(d) <= hb_raw + 1.5) & (t >= t0r + cut - 1.0) & (t <= t1r - cut + 1.0)
        cand = grid[near]
        vals_all = sub_f[(cand[:, 1] - y0).astype(int), (cand[:, 0] - x0).astype(int)].astype(float)
        cand_ideal = pm.to_ideal(cand)
        hb = hb_raw * scale
        result = None
        params = None
        line = lines[k]
        for _ in range(2):
            cl = corners_from_lines(lines)
            c0, c1 = cl[k], cl[(k + 1) % 4]
            n, tau, t0, t1 = _side_frame(line, c0, c1)
            dd = cand_ideal @ n - line[2]
            tt = cand_ideal @ tau
            cut_i = (hb_raw + opt.corner_gap) * scale
            sel = (np.abs(dd) <= hb) & (tt >= t0 + cut_i) & (tt <= t1 - cut_i)
            sel &= _along_visible_edge(tt, ideal_pts[labels == k] @ tau, t0 + cut_i, t1 - cut_i,
                                       opt.max_edge_gap * scale, cut_i)
            if sel.sum() < 12:
                return _fail(f"side {k + 1}: too few pixels along the edge to fit it", **base)
            covered = np.ptp(tt[sel]) / max(t1 - t0, 1e-6) if sel.any() else 0.0
            if covered < opt.min_side_coverage:
                return _fail(f"side {k + 1}: the edge is visible over only {100 * covered:.0f} % of its length",
                             **base)
            result = _edge_model_fit(vals_all[sel], cand_ideal[sel], line, 0.5 * (t0 + t1), 0.5 * (t1 - t0),
                                     0.8 * scale, opt.iterations, params)
            if result is None:
                return _fail(f"side {k + 1}: the edge has no dark-to-bright step (not the marker's outer square)",
                             **base)
            line, params = result[0], result[5]
            lines[k] = line
        line, cov, blur, contrast, rms, _ = result
        fits.append(SideFit(line, cov, blur, contrast, rms, int(sel.sum()), int(n_edge[k]), lines0[k]))
    if not all(0.2 * scale <= f.blur <= 4.0 * scale for f in fits):
        bad = next(i for i, f in enumerate(fits) if not 0.2 * scale <= f.blur <= 4.0 * scale)
        return _fail(f"side {bad + 1}: the edge is not a clean step (width {fits[bad].blur:.2f} px)", **base)
    try:
        corners_i = corners_from_lines(lines)
    except np.linalg.LinAlgError:
        return _fail("the four edges do not form a quadrilateral", **base)
    corners_r = pm.to_raw(corners_i)
    shift = np.linalg.norm(corners_r - predicted, axis=1).max()
    allowed = max(opt.min_corner_shift_px, opt.max_corner_shift * float(L_raw.mean()))
    if shift > allowed:
        return _fail(f"the fitted outline is {shift:.1f} px away from the predicted one (more than {allowed:.1f} px): "
                     "another edge was taken for the marker's", **base)
    ref_i = diagonal_intersection(corners_i)
    ref_r = pm.to_raw(ref_i[None])[0]
    cov = reference_covariance(lines, [f.line_cov for f in fits])
    cov = cov + (opt.sigma_floor_px * scale) ** 2 * np.eye(2)
    poly = []
    for k in range(4):
        s = np.linspace(0.0, 1.0, 16)[:, None]
        poly.append(corners_i[k] + s * (corners_i[(k + 1) % 4] - corners_i[k]))
    polyline = pm.to_raw(np.concatenate(poly))
    return OutlineFit(True, "", sides=fits, lines=lines, corners_ideal=corners_i, corners=corners_r,
                      reference_ideal=ref_i, reference=ref_r, reference_cov=cov, outline_polyline=polyline,
                      **base)
