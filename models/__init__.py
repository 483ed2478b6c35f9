"""The MJCF models of the twin, shipped as package data (read with importlib.resources)."""
