"""Eq. (22)–(25) for a rectified pair, and the sign slip of the printed (25).

Two parallel cameras, focal length f (px), baseline B (mm); the chapter's origin is midway
between them. A point (x_w, y_w, z_w) is seen at u1 = f(x_w + B/2)/z_w (left) and
u2 = f(x_w − B/2)/z_w (right), both on row v = f·y_w/z_w (u, v from the principal point).
    (23)  d = u1 − u2 = f·B/z_w        (24)  z_w = f·B/d
    (25)  x_w = B(u1 + u2)/(2d),  y_w = B·v/d     (printed with −B(u1 + u2)/(2d))
"""
import numpy as np

from core.marker.triangulation import triangulate_rectified

f, B = 1500.0, 130.0
point = np.array([42.0, -17.0, 800.0])                   # x_w, y_w, z_w (mm), midpoint origin
u1 = f * (point[0] + B / 2) / point[2]
u2 = f * (point[0] - B / 2) / point[2]
v = f * point[1] / point[2]
d = u1 - u2
print(f"u1 = {u1:.3f} px, u2 = {u2:.3f} px, v = {v:.3f} px, d = {d:.3f} px")
z = f * B / d                                             # (24)
x_plus, x_minus = B * (u1 + u2) / (2 * d), -B * (u1 + u2) / (2 * d)
y = B * v / d
print(f"(24) z_w = {z:.3f} mm;  (25) y_w = {y:.3f} mm")
print(f"(25) with +: x_w = {x_plus:.3f} mm (true {point[0]});  as printed, with −: {x_minus:.3f} mm")
assert np.isclose(d, f * B / point[2]) and np.isclose(z, point[2]) and np.isclose(y, point[1])
assert np.isclose(x_plus, point[0]) and not np.isclose(x_minus, point[0])
# u1 + u2 = 2f·x_w/z_w: the minus sign mirrors the point about the midpoint

# RoboCal measures from the left camera: X = x_w + B/2 (principal point cx, cy added to the pixels)
cx, cy = 640.0, 512.0
P1 = np.array([[f, 0, cx, 0], [0, f, cy, 0], [0, 0, 1, 0]])
P2 = np.array([[f, 0, cx, -f * B], [0, f, cy, 0], [0, 0, 1, 0]])
X = triangulate_rectified(u1 + cx, v + cy, d, P1, P2, np.eye(3)).point
print(f"RoboCal (left camera origin): X, Y, Z = {X.round(3)} = (x_w + B/2, y_w, z_w)")
assert np.allclose(X, point + [B / 2, 0, 0])

# (22) in general: s_i·p_i = M_i·P for both cameras, solved by least squares (DLT)
M1, M2 = P1, P2
P_left = np.append(X, 1.0)
rows = []
for M, (uu, vv) in ((M1, (u1 + cx, v + cy)), (M2, (u2 + cx, v + cy))):
    rows += [uu * M[2] - M[0], vv * M[2] - M[1]]
_, _, Vt = np.linalg.svd(np.array(rows))
P_dlt = Vt[-1] / Vt[-1][3]
print(f"(22) DLT: {P_dlt[:3].round(3)}")
assert np.allclose(P_dlt[:3], X, atol=1e-6)
