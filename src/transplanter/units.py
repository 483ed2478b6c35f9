"""Unit conversions between the G-code dialect's units and SI, defined once.

The firmware works in SI (m, s, rad); G-code words are in mm, mm/s (``S``), mm/min (``F``)
and ms (``G4 P``). Divide by a constant to go from SI to the G-code unit, multiply to come
back: ``x_mm = x_m / M_PER_MM``, ``x_m = x_mm * M_PER_MM``.
"""

from __future__ import annotations

import math

__all__ = ["MM_PER_MIN_TO_M_S", "M_PER_MM", "S_PER_MS", "show", "show_outside"]

M_PER_MM = 1e-3
"""Metres per millimetre (positions, and mm/s -> m/s for the ``S`` speed word)."""
S_PER_MS = 1e-3
"""Seconds per millisecond (``G4 P`` dwell)."""
MM_PER_MIN_TO_M_S = M_PER_MM / 60.0
"""Factor from mm/min (the ``F`` feed word) to m/s."""


SHOW_FIXED_BELOW = 1e6
"""Magnitudes at or above this are shown in exponent notation (no 300-digit numbers)."""


def show(value: float, decimals: int = 3) -> str:
    """A value for a message: fixed ``decimals`` below SHOW_FIXED_BELOW, else ``1.23457e+08``."""
    value = float(value)
    if not math.isfinite(value) or abs(value) >= SHOW_FIXED_BELOW:
        return f"{value:.6g}"
    return f"{value:.{decimals}f}"


def show_outside(value: float, lo: float, hi: float, decimals: int = 1) -> tuple[str, str, str]:
    """(value, lo, hi) as text with enough decimals that the value visibly lies outside.

    ``80.0 outside [80, 235]`` is what rounding gives for 79.96; this adds decimals (up to 9)
    until the shown value differs from the bound it crossed: ``79.96 outside [80, 235]``
    (bounds without trailing zeros).
    """
    for places in range(decimals, 10):
        shown = round(value, places)
        if not (round(lo, places) <= shown <= round(hi, places)):
            break

    def bound(b: float) -> str:
        text = show(b, places)
        return text.rstrip("0").rstrip(".") if "." in text and "e" not in text else text

    return show(value, places), bound(lo), bound(hi)
