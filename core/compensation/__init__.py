"""Compensation: the calibrated model turned into motion.

* `core.compensation.ik`: `solve_ik(model, targets_xyz, targets_R=None, *, tcp="marker",
  frame="base", hint=None, start=None, tol_mm=1e-6, tol_deg=1e-7, ...) -> IKResult` (Q rad/mm,
  ok, reason, error_mm, error_deg, iterations); `tcp_in_tool`, `tcp_poses`, `frame_to_world`.
* `core.compensation.prediction`: `predicted_error(model, Q, tcp, probability=0.95) ->
  PredictedError` (sigma_mm, limit_mm per point) from the calibration's covariance.
"""
