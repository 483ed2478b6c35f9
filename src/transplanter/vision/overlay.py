"""The grading drawn on the rectified picture: the cell borders the profiles found and each
cell's class (a coloured frame and a letter); cells whose class differs from a given truth get
a red cross."""

from __future__ import annotations

from collections.abc import Sequence

import cv2
import numpy as np

from transplanter.vision.grading import EMPTY, HEALTHY, HEALTHY_LR, HEALTHY_UD, INFERIOR
from transplanter.vision.pipeline import TrayGrading

# RGB colour and letter of each class in the overlay
STYLE = {
    EMPTY: ((150, 150, 150), "E"),
    INFERIOR: ((255, 140, 0), "I"),
    HEALTHY_LR: ((0, 120, 255), "LR"),
    HEALTHY_UD: ((190, 0, 255), "UD"),
    HEALTHY: ((0, 200, 80), "H"),
}


def draw_overlay(grading: TrayGrading, truth: Sequence[str] | None = None) -> np.ndarray:
    """RGB picture: the rectified tray, the borders, the classes (and the misses, with truth)."""
    out = grading.rectified.copy()
    h, w = out.shape[:2]
    s = grading.px_per_mm
    for a, b in grading.col_borders:
        for x in (a, b):
            cv2.line(out, (round(x), 0), (round(x), h - 1), (255, 255, 0), 1)
    for a, b in grading.row_borders:
        for y in (a, b):
            cv2.line(out, (0, round(y)), (w - 1, round(y)), (255, 255, 0), 1)
    half = round(12 * s)
    for cell in grading.cells:
        colour, letter = STYLE[cell.grade]
        cx, cy = (round(v) for v in cell.centre_px)
        cv2.rectangle(out, (cx - half, cy - half), (cx + half, cy + half), colour, 2)
        origin = (cx - half + 3, cy - half + round(6 * s))
        scale = 0.17 * s
        cv2.putText(out, letter, origin, cv2.FONT_HERSHEY_SIMPLEX, scale, (0, 0, 0), 3, cv2.LINE_AA)
        cv2.putText(out, letter, origin, cv2.FONT_HERSHEY_SIMPLEX, scale, colour, 1, cv2.LINE_AA)
        if truth is not None and truth[cell.index] != cell.grade:
            cv2.line(out, (cx - half, cy - half), (cx + half, cy + half), (255, 0, 0), 2)
            cv2.line(out, (cx - half, cy + half), (cx + half, cy - half), (255, 0, 0), 2)
    return out


def png_bytes(picture: np.ndarray) -> bytes:
    """An RGB (or single-channel) uint8 picture encoded as PNG."""
    image = cv2.cvtColor(picture, cv2.COLOR_RGB2BGR) if picture.ndim == 3 else picture
    ok, data = cv2.imencode(".png", image)
    if not ok:
        raise ValueError(f"could not encode a {picture.dtype} picture of {picture.shape} as PNG")
    return data.tobytes()
