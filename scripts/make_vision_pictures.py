"""Write docs/vision.md's pictures (docs/img/vision_*.png) from one held-out tray (seed 100,
default lighting, 1600x900): the camera's picture, the pipeline's stages on a corner of the
tray, the projection profiles, and the overlay of the whole tray.

Run headless: MUJOCO_GL=egl .venv/bin/python scripts/make_vision_pictures.py
"""

from __future__ import annotations

import io
import sys
from pathlib import Path

import cv2
import matplotlib
import numpy as np
from PIL import Image

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

from transplanter.studies.vision import grade_seed  # noqa: E402
from transplanter.vision.overlay import draw_overlay  # noqa: E402

IMG = Path(__file__).resolve().parent.parent / "docs" / "img"
SEED = 100


def small_png(path: Path, rgb: np.ndarray, colours: int = 64) -> None:
    """An RGB picture as a palette PNG (kept small for the repository)."""
    image = Image.fromarray(rgb).quantize(colors=colours, method=Image.Quantize.MEDIANCUT)
    out = io.BytesIO()
    image.save(out, format="PNG", optimize=True)
    path.write_bytes(out.getvalue())


def small_figure(fig, path: Path) -> None:
    buf = io.BytesIO()
    fig.savefig(buf, format="png")
    small_png(path, np.asarray(Image.open(buf).convert("RGB")), colours=32)


def main() -> int:
    graded = grade_seed(SEED, 1600, 900, "default", keep_stages=True)
    st = graded.grading.stages
    IMG.mkdir(parents=True, exist_ok=True)
    small = cv2.resize(graded.picture, (640, 360), interpolation=cv2.INTER_AREA)
    small_png(IMG / "vision_picture.png", small)
    overlay = draw_overlay(graded.grading, graded.tray.classes())
    half = overlay.shape[1] // 2  # the left eight columns, full size
    small_png(IMG / "vision_overlay.png", overlay[:, :half])

    # the stages on the tray's top-left corner (3 rows x 5 columns of cells)
    s = graded.grading.px_per_mm
    y1, x1 = round(120 * s), round(190 * s)
    panels = [
        ("rectified (tilt corrected)", st["rectified"][:y1, :x1], None),
        ("dual grey threshold", st["band"], "full"),
        ("walls: eroded, opened, leaves out", st["walls"][:y1, :x1], "gray"),
        ("leaves by HSV", st["leaves_raw"][:y1, :x1], "gray"),
        ("small components out, height-corrected", st["leaves"][:y1, :x1], "gray"),
        ("grid and classes", overlay[:y1, :x1], None),
    ]
    fig, axes = plt.subplots(2, 3, figsize=(12, 5.6), dpi=64)
    for ax, (title, image, cmap) in zip(axes.flat, panels, strict=True):
        if cmap == "full":
            ax.imshow(cv2.resize(image, (480, 270), interpolation=cv2.INTER_AREA), cmap="gray")
            title += " (whole picture)"
        else:
            ax.imshow(image, cmap=cmap)
        ax.set_title(title, fontsize=10)
        ax.set_axis_off()
    fig.tight_layout()
    small_figure(fig, IMG / "vision_stages.png")
    plt.close(fig)

    fig, (top, bottom) = plt.subplots(2, 1, figsize=(10, 4.2), dpi=80)
    for ax, key, borders, what in (
        (top, "col_profile", graded.grading.col_borders, "columns (x)"),
        (bottom, "row_profile", graded.grading.row_borders, "rows (y)"),
    ):
        profile = st[key]
        ax.plot([i / s for i in range(len(profile))], profile, lw=1, color="k")
        ax.axhline(0.5, color="tab:red", lw=0.8, ls="--")
        for a, b in borders:
            ax.axvspan(a / s, b / s, color="tab:green", alpha=0.15)
        ax.set_ylabel("wall fraction")
        ax.set_title(f"projection profile along the {what}: troughs = cell openings", fontsize=10)
        ax.set_xlim(0, len(profile) / s)
    bottom.set_xlabel("mm along the rectified tray")
    fig.tight_layout()
    small_figure(fig, IMG / "vision_profiles.png")
    plt.close(fig)
    print(f"seed {SEED}: {graded.score.correct}/{graded.score.cells}; wrote docs/img/vision_*.png")
    return 0


if __name__ == "__main__":
    sys.exit(main())
