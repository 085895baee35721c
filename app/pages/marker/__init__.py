"""The Marker step's page (page.py) and its tabs (*_panel.py); the work it runs is app/jobs/marker.py."""
