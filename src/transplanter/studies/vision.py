"""The recognition pipeline measured against drawn trays: draw a tray from a seed
(`scene.plug_tray`), photograph it in the imaging station (`scene.tray_camera`), grade the
picture (`vision.pipeline`, which sees only the picture) and score the grades against the
drawn truth (`vision.metrics`); several seeds pooled."""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from transplanter.scene.plug_tray import SeedlingDraw, TrayDraw, draw_tray
from transplanter.scene.tray_camera import Appearance, ImagingDraw, draw_appearance, render_tray
from transplanter.vision.metrics import Score, score
from transplanter.vision.pipeline import CameraMount, TrayGrading, VisionThresholds, grade_tray

LIGHTINGS = {
    "default": ImagingDraw,
    "darker": ImagingDraw.darker,
    "brighter": ImagingDraw.brighter,
}


@dataclass
class GradedTray:
    """One seed's tray, its picture, the pipeline's grading and its score."""

    seed: int
    tray: TrayDraw
    appearance: Appearance
    picture: np.ndarray
    grading: TrayGrading
    score: Score
    render_seconds: float

    def cells(self) -> list[dict]:
        """All cells: the pipeline's class and measurements beside the truth's."""
        out = []
        for g, t in zip(self.grading.cells, self.tray.cells, strict=True):
            row = g.as_dict()
            row.update(
                {
                    "truth": t.truth,
                    "drawn_kind": t.kind,
                    "true_area_mm2": round(t.area_mm2, 2),
                    "true_centroid_offset_mm": round(t.centroid_offset_mm, 2),
                    "true_secant_lr_mm": round(t.secant_lr_mm, 2),
                    "true_secant_ud_mm": round(t.secant_ud_mm, 2),
                }
            )
            out.append(row)
        return out


def grade_seed(
    seed: int,
    width: int = 1600,
    height: int = 900,
    lighting: str = "default",
    seedlings: SeedlingDraw | None = None,
    thresholds: VisionThresholds | None = None,
    keep_stages: bool = False,
    imaging: ImagingDraw | None = None,
    mount: CameraMount | None = None,
) -> GradedTray:
    """Draw, photograph, grade and score one tray. `imaging` (a scenario's [vision] draw)
    replaces the named `lighting`'s."""
    if lighting not in LIGHTINGS:
        raise ValueError(f"unknown lighting {lighting!r}; known: {', '.join(LIGHTINGS)}")
    imaging = imaging or LIGHTINGS[lighting]()
    tray = draw_tray(seed, seedlings)
    appearance = draw_appearance(seed, imaging)
    t0 = time.perf_counter()
    picture = render_tray(tray, appearance, width, height, leaf_jitter=imaging.leaf_jitter)
    render_s = time.perf_counter() - t0
    grading = grade_tray(picture, mount=mount, thresholds=thresholds, keep_stages=keep_stages)
    result = score(
        tray.classes(),
        grading.classes(),
        [c.area_mm2 for c in tray.cells],
        [c.area_mm2 for c in grading.cells],
    )
    return GradedTray(seed, tray, appearance, picture, grading, result, render_s)


def pooled(trays: Sequence[GradedTray]) -> Score:
    """The score of several trays' cells together."""
    truth, graded, true_area, area = [], [], [], []
    for t in trays:
        truth += t.tray.classes()
        graded += t.grading.classes()
        true_area += [c.area_mm2 for c in t.tray.cells]
        area += [c.area_mm2 for c in t.grading.cells]
    return score(truth, graded, true_area, area)
