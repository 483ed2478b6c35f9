"""Scenario files and example G-code, shipped as package data (read with importlib.resources)."""
