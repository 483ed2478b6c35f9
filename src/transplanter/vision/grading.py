"""The paper's grading rule for one cell, in one vocabulary shared by the drawn truth
(`transplanter.scene.plug_tray`) and the recognition pipeline (`transplanter.vision.pipeline`).

Zhao, Cheng, Dong, Ma, Xiong and Tong, "Research on the End Effector and Optimal Motion Control
Strategy for a Plug Seedling Transplanting Parallel Robot" (Agriculture 2022), Sec. 2.1: a
seedling whose leaf area is below 100 mm^2 is inferior; one whose leaf centroid lies within
10 mm of the cell centre and whose leaves cut the cell border along a secant longer than 12 mm
crosses the border (left-right or up-down, which decides how the claws grab it); within 10 mm
and no such secant it can be grabbed from any side; a centroid further off ("growing very close
to the corners") makes it inferior too. A cell without leaves is empty (holes in the tray).

Pure Python: no MuJoCo, no OpenCV.
"""

from __future__ import annotations

from dataclasses import dataclass

EMPTY, INFERIOR, HEALTHY_LR, HEALTHY_UD, HEALTHY = (
    "empty",
    "inferior",
    "healthy_lr",
    "healthy_ud",
    "healthy",
)
CLASSES = (EMPTY, INFERIOR, HEALTHY_LR, HEALTHY_UD, HEALTHY)


@dataclass(frozen=True)
class GradingRule:
    """The thresholds of the rule. The first three are the paper's; `empty_area_mm2` (below it
    a cell holds no seedling) is this project's estimate: moss specks and crumbs of green are
    a few mm^2, the smallest inferior seedling drawn is about 20 mm^2."""

    min_leaf_area_mm2: float = 100.0
    max_centroid_offset_mm: float = 10.0
    min_secant_mm: float = 12.0
    empty_area_mm2: float = 10.0


def grade(
    area_mm2: float,
    centroid_offset_mm: float,
    secant_lr_mm: float,
    secant_ud_mm: float,
    rule: GradingRule | None = None,
) -> str:
    """The class of one cell from its leaf area, the distance of the leaves' centroid from the
    cell centre, and the longest secant of the leaves with the left or right border
    (`secant_lr_mm`) and with the upper or lower border (`secant_ud_mm`). A seedling over both
    thresholds is named by the longer secant."""
    rule = rule or GradingRule()
    if area_mm2 < rule.empty_area_mm2:
        return EMPTY
    if area_mm2 < rule.min_leaf_area_mm2 or centroid_offset_mm > rule.max_centroid_offset_mm:
        return INFERIOR
    if max(secant_lr_mm, secant_ud_mm) > rule.min_secant_mm:
        return HEALTHY_LR if secant_lr_mm >= secant_ud_mm else HEALTHY_UD
    return HEALTHY
