"""Eq. (26)–(27): the SSD criteria function along one row of a rectified pair, and the window.

A textured scene row is seen by the right camera shifted by the true disparity d = u1 − u2.
C(d) = Σ over the window of (I_L(u + i) − I_R(u + i − d))² (eq. 26), and the disparity is the d
that minimises it (eq. 27). A small window sees too few grey levels to be sure (several
near-minima on repetitive texture); a large one is sure but costs more and blurs depth edges.
"""
import numpy as np

rng = np.random.default_rng(4)
width, d_true, u = 400, 23, 200
stripes = 100 + 60 * np.sign(np.sin(np.arange(width + 60) * 2 * np.pi / 8))   # period 8 px
texture = stripes + np.where(np.arange(width + 60) % 53 < 6, 50.0, 0.0)         # a few marks
left = texture[30:30 + width] + rng.normal(0, 2, width)
right = texture[30 + d_true:30 + d_true + width] + rng.normal(0, 2, width)       # I_R(u − d) = I_L(u)


def criteria(size, disparities):
    h = size // 2
    win = left[u - h:u + h + 1]
    return np.array([np.mean((win - right[u - d - h:u - d + h + 1]) ** 2) for d in disparities])


D = np.arange(0, 60)
print("window  best d  second-best C / best C")
results = {}
for size in (5, 9, 15, 25, 37):
    C = criteria(size, D)
    best = int(D[np.argmin(C)])
    others = np.delete(C, np.abs(D - best) <= 1)
    results[size] = (best, float(others.min() / max(C.min(), 1e-9)))
    print(f"{size:6d}  {best:6d}  {results[size][1]:10.1f}")
# the stripes repeat every 8 px: a 5-px window cannot tell d from d ± 8, a 37-px one sees the marks
assert results[37][0] == d_true and results[37][1] > 10
assert results[5][1] < results[37][1] / 5
