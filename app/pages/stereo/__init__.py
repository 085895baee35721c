"""Step 2, Stereo calibration: the page (page.py) and its panels."""
