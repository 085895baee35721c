"""Watching a calibrated cell (the chapter's §6): check poses, checks against the calibration's
own predicted uncertainty, an append-only check log, diagnosis of a changed geometry and
re-identification of what changed from a few poses. Plain Python, no Qt."""
