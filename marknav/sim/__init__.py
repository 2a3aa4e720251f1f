"""Simulator: world, camera renderer and the byte-level simulated Create."""
