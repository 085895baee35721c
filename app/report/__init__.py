"""The calibration report drawn with Qt: figures with pyqtgraph (figures.py), HTML with embedded
images and the PDF printed with QTextDocument (render.py)."""
