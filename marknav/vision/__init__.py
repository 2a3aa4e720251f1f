"""Vision: mark detection, frame sources, range/offset estimation and calibration."""
