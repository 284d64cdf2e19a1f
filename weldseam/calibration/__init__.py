"""Hand-eye calibration: find a calibration board in images, estimate its pose, solve AX = XB.

opencv (the `calibrate` extra) is imported inside the functions that need it, never at import time.
"""
