"""The delta host's grading map (seed 002's PC, Zhao et al. 2022 Sec. 2.1): the class of every
cell of the planting tray (inferior and empty cells are worked) and of the supply tray (its
healthy seedlings refill them), and how far each seedling's leaves reach left-right and
up-down (the pose judgement of a seedling that crosses no border).

`delta_refill.vision = "pipeline"`: both trays are photographed at the imaging station
(`scene.tray_camera`, the scenario's [vision] draw and picture size) and graded by the
recognition pipeline (`vision.pipeline.grade_tray`, the scenario's thresholds): nothing of
the draw enters. It needs an offscreen OpenGL context (MUJOCO_GL=egl or osmesa); without one,
`GradingUnavailable`; a picture the pipeline cannot read is `GradingFailed`, never a map.
`"truth"`: the drawn classes and leaves (`scene.plug_tray`), no picture.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

from transplanter.errors import TransplanterError
from transplanter.scene.plug_tray import CellTruth, TrayDraw, TrayGeometry
from transplanter.vision.grading import CLASSES

__all__ = [
    "CellGrading",
    "GradingFailed",
    "GradingMap",
    "GradingUnavailable",
    "TrayGrades",
    "from_pipeline",
    "from_truth",
    "grading_map",
    "leaf_extents_mm",
    "truth_cell",
    "truth_grades",
]

TRUTH_HINT = "or grade from the drawn truth: --set delta_refill.vision=truth"


class GradingUnavailable(TransplanterError, RuntimeError):
    """The pipeline's pictures cannot be taken: no offscreen OpenGL context."""


class GradingFailed(TransplanterError, ValueError):
    """A tray's picture cannot be graded (blank, too dark, no tray, no grid): no grading map."""


@dataclass(frozen=True)
class CellGrading:
    """One cell in the host's map: its class, and its leaves' reach from the cell centre
    left-right and up-down (mm)."""

    grade: str
    reach_lr_mm: float = 0.0
    reach_ud_mm: float = 0.0


@dataclass
class TrayGrades:
    """One tray's map (cells in index order) and, from the pipeline, what it cost: the wall
    time of rendering the picture and of the recognition, and the tilt found."""

    cells: list[CellGrading]
    render_s: float = 0.0
    recognition_s: float = 0.0
    tilt_deg: float | None = None

    def classes(self) -> list[str]:
        return [c.grade for c in self.cells]


@dataclass
class GradingMap:
    """Both trays' maps and where they came from ("pipeline" or "truth")."""

    source: str
    planting: TrayGrades
    supply: TrayGrades
    picture_px: tuple[int, int] | None = None
    extra: dict = field(default_factory=dict)

    def summary(self, planting: TrayDraw, supply: TrayDraw) -> dict:
        """The map against the drawn truth, per tray: cells graded as their truth, the
        confusion matrix (rows: truth, columns: grade, in CLASSES order) and the wall times."""
        out: dict = {"source": self.source, "classes": list(CLASSES)}
        if self.picture_px is not None:
            out["picture_px"] = list(self.picture_px)
        for name, grades, draw in (("planting", self.planting, planting),
                                   ("supply", self.supply, supply)):  # fmt: skip
            matrix = [[0] * len(CLASSES) for _ in CLASSES]
            for g, t in zip(grades.classes(), draw.classes(), strict=True):
                matrix[CLASSES.index(t)][CLASSES.index(g)] += 1
            out[name] = {
                "correct": sum(matrix[i][i] for i in range(len(CLASSES))),
                "cells": len(grades.cells),
                "confusion": matrix,
                "render_wall_s": round(grades.render_s, 4),
                "recognition_wall_s": round(grades.recognition_s, 4),
                "tilt_deg": None if grades.tilt_deg is None else round(grades.tilt_deg, 4),
            }
        return out


def leaf_extents_mm(cell: CellTruth, geometry: TrayGeometry) -> tuple[float, float]:
    """How far the seedling's blades reach from its cell's centre along x (left-right) and y
    (up-down), mm: each blade's bounding half-widths about its centre."""
    cx, cy = geometry.centre(cell.row, cell.col)
    ex = ey = 0.0
    for lf in cell.seedling.leaves if cell.seedling is not None else ():
        c, s = abs(math.cos(lf.angle_rad)), abs(math.sin(lf.angle_rad))
        hx = math.hypot(lf.radial_mm * c, lf.tangential_mm * s)
        hy = math.hypot(lf.radial_mm * s, lf.tangential_mm * c)
        ex = max(ex, abs(lf.cx - cx) + hx)
        ey = max(ey, abs(lf.cy - cy) + hy)
    return ex, ey


def truth_cell(cell: CellTruth, geometry: TrayGeometry) -> CellGrading:
    """A drawn cell's truth as the map holds it: its class and its blades' reach."""
    return CellGrading(cell.truth, *leaf_extents_mm(cell, geometry))


def truth_grades(tray: TrayDraw) -> TrayGrades:
    """A drawn tray's truth as a map: the drawn classes and the blades' reach."""
    return TrayGrades([truth_cell(c, tray.geometry) for c in tray.cells])


def from_truth(planting: TrayDraw, supply: TrayDraw) -> GradingMap:
    """The map the drawn truth gives (no picture)."""
    return GradingMap("truth", truth_grades(planting), truth_grades(supply))


def from_pipeline(sc, seed: int, planting: TrayDraw, supply: TrayDraw) -> GradingMap:
    """Both trays photographed at the imaging station and graded by the pipeline: the
    planting tray with the imaging draw of `seed`, the supply tray with that of its own seed
    (seed + supply_seed_offset), as `transplanter grade` photographs a tray of that seed."""
    from transplanter.scenario.assemble import vision_config
    from transplanter.scene.tray_camera import RenderFailed, draw_appearance, render_tray
    from transplanter.vision.pipeline import ImageUnusable, grade_tray

    vc = vision_config(sc)
    maps = []
    supply_seed = seed + sc.delta_refill.supply_seed_offset
    for name, tray, tray_seed in (("planting", planting, seed), ("supply", supply, supply_seed)):
        appearance = draw_appearance(tray_seed, vc.imaging)
        t0 = time.perf_counter()
        try:
            picture = render_tray(
                tray, appearance, vc.width_px, vc.height_px, leaf_jitter=vc.imaging.leaf_jitter
            )
        except RenderFailed as exc:
            raise GradingUnavailable(
                f'delta_refill.vision = "pipeline" photographs the trays: {exc}; {TRUTH_HINT}'
            ) from None
        render_s = time.perf_counter() - t0
        t0 = time.perf_counter()
        try:
            graded = grade_tray(picture, mount=vc.mount, thresholds=vc.thresholds)
        except ImageUnusable as exc:
            raise GradingFailed(
                f"the {name} tray's picture (seed {tray_seed}) cannot be graded: "
                f"{type(exc).__name__}: {exc}; no grading map, no job"
            ) from None
        recognition_s = time.perf_counter() - t0
        cells = [CellGrading(c.grade, c.reach_lr_mm, c.reach_ud_mm) for c in graded.cells]
        maps.append(TrayGrades(cells, render_s, recognition_s, graded.tilt_deg))
    return GradingMap("pipeline", *maps, picture_px=(vc.width_px, vc.height_px))


def grading_map(sc, seed: int, planting: TrayDraw, supply: TrayDraw) -> GradingMap:
    """The host's map as `delta_refill.vision` says."""
    if sc.delta_refill.vision == "pipeline":
        return from_pipeline(sc, seed, planting, supply)
    return from_truth(planting, supply)
