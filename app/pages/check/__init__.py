"""The Check step (8): watch the calibrated robot at its check poses, diagnose a change, re-identify it."""
