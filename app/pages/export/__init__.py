"""The Export step (7): the calibrated robot and the cameras in the formats other tools read, and the report."""
