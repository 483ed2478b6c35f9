"""The grading drawn on the rectified picture: the cell borders the profiles found and each
cell's class (a coloured frame and a letter); cells whose class differs from a given truth get
a red cross. A legend under the picture names each class's colour and letter, the borders and
the cross."""

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


LEGEND = {
    EMPTY: "empty",
    INFERIOR: "inferior",
    HEALTHY_LR: "healthy, leaves left-right",
    HEALTHY_UD: "healthy, leaves up-down",
    HEALTHY: "healthy",
}
"""What each class's letter means in the legend."""


def _legend(width: int, with_truth: bool) -> np.ndarray:
    """A white band naming each class's colour and letter, the borders and the cross."""
    entries = [(colour, f"{letter} {LEGEND[grade]}") for grade, (colour, letter) in STYLE.items()]
    entries.append(((255, 255, 0), "cell borders found"))
    if with_truth:
        entries.append(((255, 0, 0), "X graded unlike the truth"))
    row_h, pad = 22, 8
    per_row = max(1, width // 230)
    rows = -(-len(entries) // per_row)
    band = np.full((rows * row_h + pad, width, 3), 255, dtype=np.uint8)
    for i, (colour, text) in enumerate(entries):
        x, y = pad + (i % per_row) * 230, pad + (i // per_row) * row_h
        cv2.rectangle(band, (x, y), (x + 14, y + 14), colour, -1)
        cv2.rectangle(band, (x, y), (x + 14, y + 14), (0, 0, 0), 1)
        cv2.putText(band, text, (x + 20, y + 12), cv2.FONT_HERSHEY_SIMPLEX, 0.45, (0, 0, 0), 1,
                    cv2.LINE_AA)  # fmt: skip
    return band


def draw_overlay(grading: TrayGrading, truth: Sequence[str] | None = None) -> np.ndarray:
    """RGB picture: the rectified tray, the borders, the classes (and the misses, with
    truth), and the legend under it (`_legend`)."""
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
    return np.vstack([out, _legend(w, truth is not None)])


def png_bytes(picture: np.ndarray) -> bytes:
    """An RGB (or single-channel) uint8 picture encoded as PNG."""
    image = cv2.cvtColor(picture, cv2.COLOR_RGB2BGR) if picture.ndim == 3 else picture
    ok, data = cv2.imencode(".png", image)
    if not ok:
        raise ValueError(f"could not encode a {picture.dtype} picture of {picture.shape} as PNG")
    return data.tobytes()
