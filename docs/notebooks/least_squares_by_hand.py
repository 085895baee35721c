"""Eq. (5)–(10) by hand: identify a two-joint planar arm from measured tip positions.

The arm: joint angles q1, q2; link lengths a1, a2; a zero offset θ2 on joint 2. The tip is
    x = a1·cos q1 + a2·cos(q1 + q2 + θ2),   y = a1·sin q1 + a2·sin(q1 + q2 + θ2)   (mm)
g = (a1, a2, θ2) are the parameters. Φ stacks ∂(x, y)/∂g of every pose (eq. 5–7); one step of
eq. (9) is Δg = (ΦᵀΦ)⁻¹ΦᵀΔX, and eq. (10) repeats it until Δg is negligible.
"""
import numpy as np

rng = np.random.default_rng(1)
true = np.array([300.7, 249.2, np.deg2rad(0.4)])       # the real arm
nominal = np.array([300.0, 250.0, 0.0])                 # its drawing
Q = rng.uniform(-2.5, 2.5, size=(8, 2))                 # 8 poses (rad)


def tip(g, Q):
    a1, a2, t2 = g
    s = Q[:, 0] + Q[:, 1] + t2
    return np.column_stack([a1 * np.cos(Q[:, 0]) + a2 * np.cos(s), a1 * np.sin(Q[:, 0]) + a2 * np.sin(s)])


def phi(g, Q):
    """Φ: two rows (x, y) per pose, one column per parameter (eq. 5–7)."""
    a1, a2, t2 = g
    s = Q[:, 0] + Q[:, 1] + t2
    rows = []
    for (c1, s1, cs, ss) in zip(np.cos(Q[:, 0]), np.sin(Q[:, 0]), np.cos(s), np.sin(s)):
        rows += [[c1, cs, -a2 * ss], [s1, ss, a2 * cs]]
    return np.array(rows)


measured = tip(true, Q) + rng.normal(0, 0.01, size=(len(Q), 2))     # 0.01 mm noise
g = nominal.copy()
print("iteration  |ΔX| (mm)    a1 (mm)    a2 (mm)   θ2 (deg)")
for it in range(6):
    dX = (measured - tip(g, Q)).reshape(-1)                          # ΔX, eq. (6)
    P = phi(g, Q)
    dg = np.linalg.solve(P.T @ P, P.T @ dX)                          # eq. (9): normal equations
    print(f"{it:9d}  {np.linalg.norm(dX):9.4f}  {g[0]:9.3f}  {g[1]:9.3f}  {np.rad2deg(g[2]):9.4f}")
    g = g + dg                                                       # eq. (10)
    if np.max(np.abs(dg)) < 1e-9:
        break
print(f"identified: a1 {g[0]:.3f} mm, a2 {g[1]:.3f} mm, θ2 {np.rad2deg(g[2]):.4f}°  "
      f"(true {true[0]}, {true[1]}, {np.rad2deg(true[2]):.4f}°)")
assert np.allclose(g[:2], true[:2], atol=0.02) and abs(g[2] - true[2]) < np.deg2rad(0.01)

# A zero offset θ1 on joint 1 would turn the whole arm, as a turn of the base frame does: add
# its column ∂/∂θ1 = (−y, x) next to a base rotation's (also (−y, x)) and ΦᵀΦ is singular.
xy = tip(g, Q)
theta1 = np.column_stack([-xy[:, 1], xy[:, 0]]).reshape(-1, 1)
both = np.hstack([P, theta1, theta1.copy()])
s = np.linalg.svd(both, compute_uv=False)
print(f"with θ1 and a base turn: smallest singular value {s[-1]:.2e} (of {s[0]:.2e}): not identifiable")
assert s[-1] < 1e-9 * s[0]
