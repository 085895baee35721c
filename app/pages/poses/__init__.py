"""Step 4, Pose sequence: the page (page.py), its controls and results panels, and their texts."""
