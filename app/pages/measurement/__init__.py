"""Step 5, Measurement: the page (page.py) and its panels."""
