"""Stereo correspondence by area correlation: the SSD criteria function of eq. (26)–(27).

After rectification the image of a point lies on the same row in both images. For a window
of h × w pixels centred on the left reference point (u_l, v), the criteria function

    C(d) = 1/(h·w) · Σ_i Σ_j [ I_l(u_l + i, v + j) − I_r(u_l − d + i, v + j) ]²      (26)

(normalised per pixel, so that windows of different sizes compare) is evaluated for every
integer disparity d along the row; the disparity is its minimum (27), refined to sub-pixel by
a parabola through the minimum and its two neighbours. The whole curve is returned (the GUI
plots it, chapter Fig. 16), with a reliability figure: the best minimum divided by the
second-best minimum at least half a window away (near 0: unique; near 1: ambiguous, e.g. a
repeated pattern). `window_sweep` gives the minimum criteria per window size (Fig. 17).

Only the strips needed are rectified: each rectified pixel's raw position is computed from
the rectification (R, P), the distortion and K (as cv2.initUndistortRectifyMap does) and
sampled with cv2.remap; the left window is centred exactly (sub-pixel) on the reference point.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import cv2
import numpy as np

from core.stereo.rectification import StereoRectification, remap_region

DEFAULT_MAX_RELIABILITY = 0.6
DEFAULT_MAX_MISMATCH = 0.5


@dataclass
class Correspondence:
    """The SSD search along the epipolar line (what the GUI plots: the criteria curve).

    Rectified coordinates: the left window is centred on `left_point` (u_l, v); the right
    window at disparity d is centred on (u_l − d, v). `plain_criteria` is the criteria function
    of eq. (26) over the whole search range (Fig. 16); `criteria` the curve searched (the same,
    or the pre-warped one described below).

    With the marker plane's normal (`plane_normal`, from its outline in the left image) the
    minimum is refined with the window warped by the plane: the disparity of a plane varies
    across the window (its 1/Z is affine in the image), so a tilted marker's two views differ
    by more than a shift; the refined criteria compares pixel (u_l + i, v + j) with
    (u_l + i − d·g(i, j), v + j), g the plane's relative disparity (1 at the centre), and
    only d is searched. `disparity`, `minimum`, `second_minimum` and `reliability` then
    refer to this refined criteria (`warped` True); the plain figures stay in `plain_*`. The
    search itself runs with the left window pre-warped for a guessed disparity (from the
    marker's apparent size), so that its curve (`criteria`) has its minimum at the marker
    even at 400 mm and 60° of tilt, where the plain curve may not."""

    ok: bool
    reason: str
    left_point: np.ndarray                 # (2,) rectified px
    window: tuple[int, int]                # (h, w) px, odd
    disparities: np.ndarray                # (K,) tested disparities (u_l − integer right centres)
    criteria: np.ndarray                   # (K,) C(d) searched (pre-warped when `warped`), grey levels² per pixel
    disparity: float = float("nan")        # sub-pixel disparity of the minimum, px
    minimum: float = float("nan")          # C at the minimum (grey levels² per pixel)
    second_disparity: float = float("nan")
    second_minimum: float = float("nan")
    reliability: float = float("nan")      # minimum / second minimum, + NOISE_FLOOR each (0 unique … 1 ambiguous)
    mismatch: float = float("nan")         # minimum / variance of the left window
    sigma_disparity: float = float("nan")  # px, from the curvature and the residual at the minimum
    parabola: tuple[float, float, float] | None = None   # plain C ≈ a·x² + b·x + c, x = d − integer minimum
    warped: bool = False
    plain_criteria: np.ndarray | None = None   # (K,) the plain eq. (26) curve
    plain_disparity: float = float("nan")
    plain_minimum: float = float("nan")
    plain_second_minimum: float = float("nan")
    plain_reliability: float = float("nan")
    refined_disparities: np.ndarray = field(default_factory=lambda: np.zeros(0))   # warped criteria samples
    refined_criteria: np.ndarray = field(default_factory=lambda: np.zeros(0))

    @property
    def right_point(self) -> np.ndarray:
        return np.array([self.left_point[0] - self.disparity, self.left_point[1]])


@dataclass
class WindowSweep:
    """Minimum criteria per window size (chapter Fig. 17)."""

    sizes: np.ndarray            # (S,) odd window sides, px
    minima: np.ndarray           # (S,) minimum of C, grey levels² per pixel
    disparities: np.ndarray      # (S,) sub-pixel disparity at the minimum
    reliabilities: np.ndarray    # (S,)


REFINE_PIXELS = 6000    # samples of the window used by the plane-warped refinement (at most, about)
NOISE_FLOOR = 0.5       # grey levels² per pixel: about the quantisation noise of two 8-bit images


def _ratio(best: float, second: float) -> float:
    """Reliability: best / second minimum, both with the noise floor added (so that two exact
    matches, 0 and 0, count as ambiguous rather than 0 / 0)."""
    return float((best + NOISE_FLOOR) / (second + NOISE_FLOOR))


def odd(n: float, lo: int = 3, hi: int = 401) -> int:
    k = int(round(n))
    k = k if k % 2 == 1 else k + 1
    return int(min(max(k, lo), hi if hi % 2 == 1 else hi - 1))


def _local_minima(c: np.ndarray) -> np.ndarray:
    if len(c) < 3:
        return np.zeros(0, int)
    inner = (c[1:-1] <= c[:-2]) & (c[1:-1] <= c[2:])
    return np.nonzero(inner)[0] + 1


def ssd_curve(left_patch: np.ndarray, right_strip: np.ndarray) -> np.ndarray:
    """C for every horizontal position of the left patch (h × w) in the right strip (h × W),
    normalised per pixel. NaN pixels (outside the image) count as a large difference."""
    h, w = left_patch.shape
    lp = np.nan_to_num(left_patch, nan=0.0).astype(np.float32)
    rs = np.nan_to_num(right_strip, nan=-1000.0).astype(np.float32)
    c = cv2.matchTemplate(rs, lp, cv2.TM_SQDIFF)[0].astype(np.float64)
    return np.maximum(c, 0.0) / float(h * w)


def _parabola_vertex(cm: float, c0: float, cp: float) -> tuple[float, float]:
    """Offset (in steps, within ±0.5... ±1) of the vertex of the parabola through (−1, cm),
    (0, c0), (1, cp), and its curvature coefficient a (C ≈ a·x² + ...)."""
    if not (np.isfinite(cm) and np.isfinite(c0) and np.isfinite(cp)):
        return 0.0, 0.0
    denom = cm - 2.0 * c0 + cp
    if denom <= 0:
        return 0.0, 0.0
    return float(np.clip(0.5 * (cm - cp) / denom, -1.0, 1.0)), 0.5 * denom


def plane_disparity_ratio(normal: np.ndarray, K: np.ndarray, X: np.ndarray, Y: np.ndarray, u0: float,
                          v0: float) -> np.ndarray:
    """g(X, Y) = d(X, Y) / d(u0, v0) on a plane of normal `normal` (rectified camera frame):
    d ∝ 1/Z = n·K⁻¹(x, y, 1) / (n·t)."""
    Ki = np.linalg.inv(np.asarray(K, float)[:3, :3])
    n = np.asarray(normal, float) @ Ki          # n·K⁻¹p = (nᵀK⁻¹)·p
    num = n[0] * X + n[1] * Y + n[2]
    den = n[0] * u0 + n[1] * v0 + n[2]
    return num / den


class _Warped:
    """The refined (plane-warped) criteria at the left point, for any real disparity."""

    def __init__(self, rect: StereoRectification, right: np.ndarray, patch: np.ndarray, u: float, v: float,
                 g: np.ndarray, I: np.ndarray, J: np.ndarray):
        self.rect, self.right, self.patch = rect, right, patch
        self.u, self.v, self.g, self.I, self.J = u, v, g, I, J
        self.off = rect.disparity_offset
        self.cache: dict[float, float] = {}
        self.anchors: dict[int, tuple] = {}

    def _maps(self, d: float):
        """Raw right-image positions of the warped window at disparity d: exact at the anchor
        (a whole disparity), linear within 4 px of it (the rectification map's curvature over
        a few pixels is ~1e-5 px)."""
        near = [a for a in self.anchors if abs(a - d) <= 4.0]
        if near:
            a = min(near, key=lambda k: abs(k - d))
        else:
            a = int(np.round(d))
            X0 = self.u + self.I - (self.off + (a - self.off) * self.g)
            Y = self.v + self.J
            mx0, my0 = self.rect.raw_of("right", X0, Y)
            mx1, my1 = self.rect.raw_of("right", X0 - self.g, Y)
            self.anchors[a] = (mx0, my0, mx1 - mx0, my1 - my0)
        mx0, my0, dx, dy = self.anchors[a]
        t = np.float32(d - a)
        return mx0 + t * dx, my0 + t * dy

    def __call__(self, d: float, stride: int = 1) -> float:
        """The warped criteria at disparity d (on every `stride`-th pixel of the window)."""
        if not np.isfinite(d):
            return float("inf")
        key = (round(float(d), 6), stride)
        if key not in self.cache:
            mx, my = self._maps(d)
            if stride > 1:
                mx, my, patch = mx[::stride, ::stride], my[::stride, ::stride], self.patch[::stride, ::stride]
            else:
                patch = self.patch
            samples = remap_region(self.right, mx, my)
            diff = patch - samples
            bad = ~np.isfinite(diff)
            if bad.mean() > 0.02:
                self.cache[key] = float("inf")
            else:
                self.cache[key] = float(np.mean(diff[~bad] ** 2))
        return self.cache[key]

    def refine(self, d_start: float, reach: int = 2, max_walk: int = 6, fine: bool = True,
               stride: int = 1) -> tuple[float, float, float]:
        """(disparity, minimum, curvature a) of the warped criteria near `d_start` (`fine`
        False: the integer grid and one parabola only)."""
        base = float(np.round(d_start))
        vals = {k: self(base + k, stride) for k in range(-reach, reach + 1)}
        for _ in range(max_walk):                     # walk downhill past the edge of the grid
            k_min = min(vals, key=vals.get)
            if k_min == min(vals):
                vals[k_min - 1] = self(base + k_min - 1, stride)
            elif k_min == max(vals):
                vals[k_min + 1] = self(base + k_min + 1, stride)
            else:
                break
        k_min = min(vals, key=vals.get)
        if k_min - 1 not in vals or k_min + 1 not in vals or not np.isfinite(vals[k_min]):
            return base + k_min, vals[k_min], 0.0
        delta, a = _parabola_vertex(vals[k_min - 1], vals[k_min], vals[k_min + 1])
        d1 = base + k_min + float(np.clip(delta, -0.5, 0.5))
        if not fine:
            # the parabola's vertex value: comparable between candidates off the integer grid
            b = 0.5 * (vals[k_min + 1] - vals[k_min - 1])
            return d1, max(vals[k_min] - b * b / (4.0 * a), 0.0) if a > 0 else vals[k_min], a
        # second pass: a parabola on a finer grid around the first estimate
        h = 0.3
        cm, c0, cp = self(d1 - h, stride), self(d1, stride), self(d1 + h, stride)
        delta2, a2 = _parabola_vertex(cm, c0, cp)
        if a2 > 0:
            d2 = d1 + h * float(np.clip(delta2, -1.0, 1.0))
            return d2, min(self(d2, stride), c0), a2 / (h * h)
        return d1, c0, a


def _prewarped_template(rect: StereoRectification, left: np.ndarray, normal: np.ndarray, u: float, v: float,
                        I: np.ndarray, J: np.ndarray, d_guess: float) -> np.ndarray:
    """The left window as the right camera sees it if the plane's disparity at the centre is
    `d_guess`: right offset I' shows the left offset x with x − (d(x) − d(0)) = I'."""
    off = rect.disparity_offset
    x = I.copy()
    for _ in range(3):
        g = plane_disparity_ratio(normal, rect.P1, u + x, v + J, u, v)
        x = I + (d_guess - off) * (g - 1.0)
    return rect.sample(left, "left", u + x, v + J)


def find_disparity(rect: StereoRectification, left: np.ndarray, right: np.ndarray, left_point, *,
                   window: tuple[int, int] | None = None, d_range: tuple[float, float] | None = None,
                   plane_normal: np.ndarray | None = None, disparity_guess: float | None = None,
                   max_reliability: float = DEFAULT_MAX_RELIABILITY,
                   max_mismatch: float = DEFAULT_MAX_MISMATCH, candidates: int = 3) -> Correspondence:
    """Eq. (26)–(27): the disparity of the rectified left point `left_point` (u_l, v).

    `window` (h, w) px (odd; default 21 × 21); `d_range` (d_min, d_max) px searched (default:
    the whole row of the right image, so that a best match at d ≤ 0 is seen and refused).
    `plane_normal` (3,) in the rectified left camera frame and `disparity_guess` (px, e.g.
    from the marker's apparent size): the search runs with the left window pre-warped as the
    right camera would see the plane at that disparity, and the `candidates` lowest minima
    are refined with the exactly warped window (see Correspondence); the best is the match,
    the second gives the reliability. The result is not ok, with the reason, when the window
    leaves the image, the minimum is at the end of the range, at d ≤ 0, ambiguous
    (reliability above `max_reliability`) or a poor match (minimum above `max_mismatch`
    times the window's grey-level variance)."""
    u, v = float(left_point[0]), float(left_point[1])
    h, w = (21, 21) if window is None else (odd(window[0]), odd(window[1]))
    W, Himg = rect.image_size
    hw, hh = (w - 1) // 2, (h - 1) // 2
    off = rect.disparity_offset
    if d_range is None:
        d_range = (u - (W - 1) - hw, u + hw)
    d_lo, d_hi = float(d_range[0]), float(d_range[1])
    empty = Correspondence(False, "", np.array([u, v]), (h, w), np.zeros(0), np.zeros(0))
    ys = v + np.arange(-hh, hh + 1)
    xs_l = u + np.arange(-hw, hw + 1)
    if xs_l[0] < 0 or xs_l[-1] > W - 1 or ys[0] < 0 or ys[-1] > Himg - 1:
        empty.reason = "the correlation window leaves the left image"
        return empty
    patch = rect.rectify_strip(left, "left", xs_l, ys)
    if np.isnan(patch).mean() > 0.02:
        empty.reason = "the correlation window leaves the left image"
        return empty
    # right centres: integer columns c with u - c in [d_lo, d_hi]
    c_lo = max(int(np.ceil(u - d_hi)), -hw)
    c_hi = min(int(np.floor(u - d_lo)), W - 1 + hw)
    if c_hi - c_lo < 4:
        empty.reason = "the disparity search range is empty"
        return empty
    xs_r = np.arange(c_lo - hw, c_hi + hw + 1, dtype=float)
    strip = rect.rectify_strip(right, "right", xs_r, ys)
    plain = ssd_curve(patch, strip)[::-1]                 # position j <-> right centre c_lo + j
    disp = (u - (c_lo + np.arange(len(plain))))[::-1]     # increasing disparity for plotting
    var = max(float(np.var(np.nan_to_num(patch))), 1e-9)
    n = h * w
    sep = max(hw, 3)

    def minima_of(curve):
        i0 = int(np.argmin(curve))
        mins = _local_minima(curve)
        far = mins[np.abs(mins - i0) > sep]
        j2 = int(far[np.argmin(curve[far])]) if len(far) else None
        return i0, j2, mins

    res = Correspondence(False, "", np.array([u, v]), (h, w), disp, plain, plain_criteria=plain)
    i0, j2, _ = minima_of(plain)
    res.plain_minimum = float(plain[i0])
    res.plain_second_minimum = float(plain[j2]) if j2 is not None else float(plain.max())
    res.plain_reliability = _ratio(res.plain_minimum, res.plain_second_minimum)
    if 0 < i0 < len(plain) - 1:
        delta, a = _parabola_vertex(plain[i0 - 1], plain[i0], plain[i0 + 1])
        res.plain_disparity = float(disp[i0] + np.clip(delta, -0.5, 0.5))
        res.parabola = (float(a), float(0.5 * (plain[i0 + 1] - plain[i0 - 1])), float(plain[i0]))
    else:
        res.plain_disparity = float(disp[i0])

    if plane_normal is None:
        crit = plain
        res.disparity, res.minimum = res.plain_disparity, res.plain_minimum
        res.second_minimum, res.reliability = res.plain_second_minimum, res.plain_reliability
        res.second_disparity = float(disp[j2]) if j2 is not None else float("nan")
        a = res.parabola[0] if res.parabola else 0.0
        res.sigma_disparity = float(np.sqrt(max(res.minimum, 1e-6) / (n * a))) if a > 0 else float("inf")
        best_index = i0
    else:
        J, I = np.mgrid[-hh:hh + 1, -hw:hw + 1].astype(float)
        g = plane_disparity_ratio(plane_normal, rect.P1, u + I, v + J, u, v)
        warped = _Warped(rect, right, patch, u, v, g, I, J)
        # large windows are sampled on a sparser grid (at most ~REFINE_PIXELS samples for the
        # refinement, 4x fewer for comparing the candidates): thousands of pixels already pin
        # the disparity to a few thousandths of a pixel
        fine_st = max(1, int(np.ceil(np.sqrt(h * w / REFINE_PIXELS))))
        st = 2 * fine_st if h * w > 2500 else fine_st
        guess = res.plain_disparity if disparity_guess is None else float(disparity_guess)
        refined = []
        crit = plain
        for _ in range(2):
            template = _prewarped_template(rect, left, plane_normal, u, v, I, J, guess)
            crit = ssd_curve(template, strip)[::-1]
            mins = _local_minima(crit)
            order = mins[np.argsort(crit[mins])] if len(mins) else np.array([int(np.argmin(crit))])
            chosen: list[int] = []
            for m in order:
                if all(abs(m - c) > sep for c in chosen):
                    chosen.append(int(m))
                if len(chosen) >= candidates:
                    break
            coarse = sorted((warped.refine(float(disp[m]), reach=1, fine=False, stride=st) + (m,) for m in chosen),
                            key=lambda r: r[1])
            # the two best are refined alike on the full window: best and second are compared fairly
            refined = sorted((warped.refine(c[0], reach=1, stride=fine_st) + (c[3],) for c in coarse[:2]),
                             key=lambda r: r[1])
            best_d = refined[0][0]
            if abs(best_d - guess) <= max(2.0, 0.03 * abs(guess - off)):
                break
            guess = best_d          # the size guess was off: warp for the disparity found, search again
        d1, m1, a1, best_index = refined[0]
        res.warped = True
        res.disparity, res.minimum = d1, m1
        n_used = ((h + fine_st - 1) // fine_st) * ((w + fine_st - 1) // fine_st)
        res.sigma_disparity = float(np.sqrt(max(m1, 1e-6) / (n_used * a1))) if a1 > 0 else float("inf")
        if len(refined) > 1:
            res.second_disparity, res.second_minimum = refined[1][0], refined[1][1]
        else:
            res.second_minimum = float(crit.max())
        res.reliability = _ratio(res.minimum, res.second_minimum)
        ks = sorted(k for k in warped.cache if k[1] == fine_st)
        res.refined_disparities = np.array([k[0] for k in ks])
        res.refined_criteria = np.array([warped.cache[k] for k in ks])
        res.criteria = crit
    res.mismatch = res.minimum / var
    if best_index == 0 or best_index == len(crit) - 1 or not np.isfinite(res.minimum):
        res.reason = (f"no minimum of the criteria function inside the search range (best at its end, "
                      f"d = {res.disparity:.1f} px)")
        return res
    if res.mismatch > max_mismatch:
        res.reason = (f"no good match along the epipolar line in the right image (the best leaves "
                      f"{100 * res.mismatch:.0f} % of the window's contrast unexplained): the marker is hidden "
                      "or outside the right view, or the stereo calibration no longer fits the cameras")
        return res
    if res.reliability > max_reliability:
        res.reason = (f"ambiguous SSD minimum: best / second-best = {res.reliability:.2f} (limit {max_reliability}), "
                      f"at d = {res.disparity:.1f} and {res.second_disparity:.1f} px: a repeated pattern or a second "
                      "marker-like object on the same line")
        return res
    if res.disparity - off <= 0:
        res.reason = (f"disparity {res.disparity - off:.2f} px ≤ 0: the best match along the epipolar line "
                      "lies at or beyond infinity, so it is not the marker")
        return res
    res.ok = True
    return res


def window_sweep(rect: StereoRectification, left: np.ndarray, right: np.ndarray, left_point, *,
                 sizes=tuple(range(5, 38, 2)), d_range: tuple[float, float] | None = None) -> WindowSweep:
    """The minimum of the criteria function for square windows of each size (Fig. 17)."""
    sizes = np.asarray(list(sizes), dtype=int)
    minima, disps, rel = [], [], []
    for s in sizes:
        c = find_disparity(rect, left, right, left_point, window=(int(s), int(s)), d_range=d_range,
                           max_reliability=1.0, max_mismatch=np.inf)
        minima.append(c.minimum)
        disps.append(c.disparity)
        rel.append(c.reliability)
    return WindowSweep(sizes, np.array(minima, float), np.array(disps, float), np.array(rel, float))
