"""Step 1, Setup: the page (page.py), the robot connection panel (robot_panel.py) and the
cameras panel (cameras_panel.py)."""
