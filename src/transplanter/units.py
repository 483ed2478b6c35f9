"""Unit conversions between the G-code dialect's units and SI, defined once.

The firmware works in SI (m, s, rad); G-code words are in mm, mm/s (``S``), mm/min (``F``)
and ms (``G4 P``). Divide by a constant to go from SI to the G-code unit, multiply to come
back: ``x_mm = x_m / M_PER_MM``, ``x_m = x_mm * M_PER_MM``.
"""

from __future__ import annotations

__all__ = ["MM_PER_MIN_TO_M_S", "M_PER_MM", "S_PER_MS"]

M_PER_MM = 1e-3
"""Metres per millimetre (positions, and mm/s -> m/s for the ``S`` speed word)."""
S_PER_MS = 1e-3
"""Seconds per millisecond (``G4 P`` dwell)."""
MM_PER_MIN_TO_M_S = M_PER_MM / 60.0
"""Factor from mm/min (the ``F`` feed word) to m/s."""
