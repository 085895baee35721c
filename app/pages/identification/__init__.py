"""Step 6, Identification: the page (page.py) and its panels."""
