"""What a robot model's geometry gives before any measurement is read: the identification
parameters and the calibration Jacobian (`jacobian`), the predicted marker frames and their
Jacobian rows (`orientation`), and which parameters a set of configurations can determine,
with the observability indices of pose sets (`identifiability`). Used by pose selection,
identification and monitoring; depends only on the robot model."""
