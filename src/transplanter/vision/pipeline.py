"""Seed 002's recognition pipeline (Zhao et al. 2022, Sec. 2.1) in OpenCV: one picture of a plug
tray in, the class of every cell out.

1. Grey levels, normalised by the picture's white point (a high percentile), so that the
   thresholds hold under brighter and darker lighting.
2. The tray frame by a dual grey threshold (pixels between T1 and T2 -> 255), closed; its
   outline's minimum-area rectangle gives the tilt and the four corners.
3. Tilt correction: the corners mapped onto the tray's nominal rectangle (566 x 286 mm) at
   `px_per_mm`, a perspective warp; the picture is now in tray millimetres.
4. The cell walls: the dual threshold again on the warped picture, leaf pixels taken out,
   eroded and opened (perlite grains and crumbs go); projection profiles of the walls along
   columns and rows; their troughs are the cell openings, whose ends are the cell borders.
5. Leaves by HSV (hue, saturation and value bounds), small connected components removed
   (moss specks), shifted back for their height above the tray (the camera's calibration).
6. Per cell: the leaf pixels in its pitch square connected to its core disk (the stem's
   place: a neighbour's leaf tip reaching over the wall is not counted), their area in mm^2,
   centroid offset from the cell centre, and the secants with the four borders.
7. The paper's rule (`transplanter.vision.grading`) gives each cell's class.

Nothing of a drawn tray's truth enters: the pipeline knows the tray's nominal layout (rows,
columns, outer size: what the machine is set up for) and the camera's mounting height.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import cv2
import numpy as np

from transplanter.errors import TransplanterError
from transplanter.vision.grading import GradingRule, grade


class ImageUnusable(TransplanterError, ValueError):
    """The picture cannot be graded: not an RGB image, blank, too dark or too small."""


class TrayNotFound(ImageUnusable):
    """No tray-shaped frame in the picture."""


class GridNotFound(ImageUnusable):
    """The projection profiles do not show the tray's rows and columns of cells."""


@dataclass(frozen=True)
class TrayLayout:
    """The tray the machine is set up for (seed 002's 128-cell tray): its outer size and its
    rows x columns of cells."""

    rows: int = 8
    cols: int = 16
    length_mm: float = 566.0
    width_mm: float = 286.0


@dataclass(frozen=True)
class CameraMount:
    """Where the camera hangs: its height above the tray's top face, and the height above it
    at which leaves are assumed to lie (an estimate: 10-25 day seedlings' cotyledons stand
    8-20 mm above the substrate). A leaf at height z looks H / (H - z) times further from
    the camera's nadir than it is; the leaf mask is scaled back by (H - z) / H."""

    height_mm: float = 3000.0
    leaf_height_mm: float = 14.0


@dataclass(frozen=True)
class VisionThresholds:
    """The pipeline's thresholds, chosen on seeds 0-4 of the default draw (docs/vision.md says
    why each value). Grey levels are fractions of the white point (the `white_percentile`
    percentile of the grey picture); OpenCV's hue is 0-180 (degrees / 2), saturation and value
    0-255."""

    white_percentile: float = 99.5
    min_white_level: float = 25.0
    min_contrast: float = 8.0
    tray_band: tuple[float, float] = (0.65, 1.01)
    close_fraction: float = 1 / 150
    erode_mm: float = 1.0
    open_mm: float = 2.0
    tray_aspect_tolerance: float = 0.12
    px_per_mm: float = 2.0
    profile_level: float = 0.5
    hue: tuple[int, int] = (28, 95)
    min_saturation: int = 45
    min_value: int = 35
    min_component_mm2: float = 6.0
    core_radius_mm: float = 12.0
    rule: GradingRule = field(default_factory=GradingRule)


@dataclass(frozen=True)
class CellGrade:
    """One cell's measurements and class. Centre in the rectified picture's pixels; lengths
    in mm, area in mm^2."""

    index: int
    row: int
    col: int
    grade: str
    area_mm2: float
    centroid_offset_mm: float
    secant_lr_mm: float
    secant_ud_mm: float
    centre_px: tuple[float, float]
    reach_lr_mm: float = 0.0
    """How far the cell's leaves reach from its centre left or right (the pose judgement of a
    seedling that crosses no border: the claws go in across its narrower side)."""
    reach_ud_mm: float = 0.0
    """... and up or down."""

    def as_dict(self) -> dict:
        return {
            "index": self.index,
            "row": self.row,
            "col": self.col,
            "class": self.grade,
            "area_mm2": round(self.area_mm2, 2),
            "centroid_offset_mm": round(self.centroid_offset_mm, 2),
            "secant_lr_mm": round(self.secant_lr_mm, 2),
            "secant_ud_mm": round(self.secant_ud_mm, 2),
            "reach_lr_mm": round(self.reach_lr_mm, 2),
            "reach_ud_mm": round(self.reach_ud_mm, 2),
        }


@dataclass
class TrayGrading:
    """The pipeline's result: every cell (index order), the cell borders in the rectified
    picture (pixels: columns' left/right, rows' top/bottom), the tray's tilt in the picture,
    the time taken, and the stages' pictures when asked for."""

    cells: list[CellGrade]
    col_borders: list[tuple[float, float]]
    row_borders: list[tuple[float, float]]
    tilt_deg: float
    px_per_mm: float
    seconds: float
    rectified: np.ndarray
    stages: dict[str, np.ndarray] = field(default_factory=dict)

    def classes(self) -> list[str]:
        return [c.grade for c in self.cells]


def _odd(n: float) -> int:
    k = max(1, round(n))
    return k if k % 2 else k + 1


def _kernel(size_px: float) -> np.ndarray:
    k = _odd(size_px)
    return cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (k, k))


def check_image(image: object) -> np.ndarray:
    """The picture as a contiguous (H, W, 3) uint8 RGB array, or ImageUnusable saying why."""
    if not isinstance(image, np.ndarray):
        raise ImageUnusable(f"not an image array: {type(image).__name__}")
    if image.dtype != np.uint8 or image.ndim != 3 or image.shape[2] != 3:
        raise ImageUnusable(
            f"need an (H, W, 3) uint8 RGB picture, got {image.dtype} of shape {image.shape}"
        )
    if min(image.shape[:2]) < 64:
        raise ImageUnusable(f"picture of {image.shape[1]}x{image.shape[0]} px is too small")
    return np.ascontiguousarray(image)


def _white_point(grey: np.ndarray, th: VisionThresholds) -> float:
    white = float(np.percentile(grey, th.white_percentile))
    if white < th.min_white_level:
        raise ImageUnusable(
            f"picture too dark: its white point is grey level {white:.1f} "
            f"(below {th.min_white_level:g} of 255)"
        )
    if float(grey.std()) < th.min_contrast:
        raise ImageUnusable(
            f"blank picture: grey levels vary by {float(grey.std()):.2f} "
            f"(standard deviation below {th.min_contrast:g})"
        )
    return white


def _band(norm: np.ndarray, th: VisionThresholds) -> np.ndarray:
    lo, hi = th.tray_band
    return ((norm >= lo) & (norm <= hi)).astype(np.uint8) * 255


def _order_corners(box: np.ndarray) -> np.ndarray:
    """Corners as top-left, top-right, bottom-right, bottom-left (picture rows grow down)."""
    s = box.sum(axis=1)
    d = box[:, 0] - box[:, 1]
    return np.array([box[np.argmin(s)], box[np.argmax(d)], box[np.argmax(s)], box[np.argmin(d)]])


def _runs(low: np.ndarray) -> list[tuple[int, int]]:
    """[start, end] (inclusive) of every run of True."""
    padded = np.concatenate([[False], low, [False]]).astype(np.int8)
    edges = np.flatnonzero(np.diff(padded))
    return [(int(a), int(b) - 1) for a, b in zip(edges[::2], edges[1::2], strict=True)]


def _openings(profile: np.ndarray, count: int, level: float, what: str) -> list[tuple[int, int]]:
    runs = [r for r in _runs(profile < level) if r[0] > 0 and r[1] < len(profile) - 1]
    if len(runs) > count:  # drop the narrowest (a gap in a wall under leaves)
        keep = sorted(sorted(runs, key=lambda r: r[1] - r[0])[-count:])
        runs = keep
    if len(runs) != count:
        raise GridNotFound(
            f"the {what} profile shows {len(runs)} cell openings, the tray has {count}"
        )
    widths = np.array([b - a + 1 for a, b in runs], dtype=float)
    if widths.min() < 0.5 * np.median(widths):
        raise GridNotFound(f"the {what} profile's openings are irregular: widths {widths}")
    return runs


def _measure_cell(
    patch: np.ndarray,
    centre: tuple[float, float],
    lr_borders: tuple[float, float],
    ud_borders: tuple[float, float],
    s: float,
    core_r: float,
) -> tuple[float, float, float, float, float, float]:
    """(area mm^2, centroid offset mm, secant with the left/right and with the upper/lower
    border mm, reach left/right and up/down from the centre mm) of the leaf pixels of a cell's
    pitch square (`patch`) that are connected to its core disk; borders and centre in the
    patch's pixels."""
    ccx, ccy = centre
    mine = np.zeros(patch.shape, dtype=bool)
    if patch.any():
        _, labels = cv2.connectedComponents(patch, connectivity=8)
        yy, xx = np.mgrid[0 : patch.shape[0], 0 : patch.shape[1]]
        core = (xx - ccx) ** 2 + (yy - ccy) ** 2 <= core_r * core_r
        touching = np.unique(labels[core & (labels > 0)])
        mine = np.isin(labels, touching) & (labels > 0)
    area = float(mine.sum()) / (s * s)
    offset = reach_lr = reach_ud = 0.0
    if area > 0:
        ys, xs = np.nonzero(mine)
        offset = math.hypot(xs.mean() - ccx, ys.mean() - ccy) / s
        reach_lr = (float(np.abs(xs - ccx).max()) + 0.5) / s  # to the far edge of the pixel
        reach_ud = (float(np.abs(ys - ccy).max()) + 0.5) / s
    per_col = mine.sum(axis=0).astype(float) / s
    per_row = mine.sum(axis=1).astype(float) / s
    lr = max(_at(per_col, lr_borders[0]), _at(per_col, lr_borders[1]))
    ud = max(_at(per_row, ud_borders[0]), _at(per_row, ud_borders[1]))
    return area, offset, lr, ud, reach_lr, reach_ud


def _at(lengths: np.ndarray, x: float) -> float:
    """The leaf length on the pixel lines at sub-pixel position x (pixel i's centre at i),
    interpolated between the two lines either side: the secant right on a border that lies
    between a wall pixel and an opening pixel."""
    i = math.floor(x)
    w = x - i
    lo = lengths[i] if 0 <= i < len(lengths) else 0.0
    hi = lengths[i + 1] if 0 <= i + 1 < len(lengths) else 0.0
    return float((1 - w) * lo + w * hi)


def grade_tray(
    image: np.ndarray,
    layout: TrayLayout | None = None,
    mount: CameraMount | None = None,
    thresholds: VisionThresholds | None = None,
    keep_stages: bool = False,
) -> TrayGrading:
    """Grade every cell of the tray in an RGB picture taken from straight above it."""
    t0 = time.perf_counter()
    layout = layout or TrayLayout()
    mount = mount or CameraMount()
    th = thresholds or VisionThresholds()
    image = check_image(image)
    stages: dict[str, np.ndarray] = {}
    grey = cv2.cvtColor(image, cv2.COLOR_RGB2GRAY)
    white = _white_point(grey, th)
    norm = grey.astype(np.float32) / white

    # 2. the frame: dual threshold, closed; its outline's rectangle
    band = _band(norm, th)
    h, w = grey.shape
    frame = cv2.morphologyEx(band, cv2.MORPH_CLOSE, _kernel(max(h, w) * th.close_fraction))
    contours, _ = cv2.findContours(frame, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_SIMPLE)
    if not contours:
        raise TrayNotFound("no pixel lies in the tray's grey band")
    outline = max(contours, key=cv2.contourArea)
    if cv2.contourArea(outline) < 0.05 * h * w:
        raise TrayNotFound(
            f"the largest frame-coloured region covers {cv2.contourArea(outline) / (h * w):.1%} "
            "of the picture (a tray needs at least 5 %)"
        )
    (cx, cy), (rw, rh), angle = cv2.minAreaRect(outline)
    long_side, short_side = max(rw, rh), min(rw, rh)
    aspect = layout.length_mm / layout.width_mm
    if abs(long_side / short_side / aspect - 1) > th.tray_aspect_tolerance:
        raise TrayNotFound(
            f"the frame's rectangle is {long_side:.0f} x {short_side:.0f} px "
            f"(aspect {long_side / short_side:.2f}; the tray's is {aspect:.2f})"
        )
    corners = _order_corners(cv2.boxPoints(((cx, cy), (rw, rh), angle)))
    top = corners[1] - corners[0]
    tilt_deg = math.degrees(math.atan2(float(top[1]), float(top[0])))

    # 3. tilt correction onto the tray's rectangle in mm
    s = th.px_per_mm
    out_w, out_h = round(layout.length_mm * s), round(layout.width_mm * s)
    target = np.float32([[0, 0], [out_w, 0], [out_w, out_h], [0, out_h]])
    homography = cv2.getPerspectiveTransform(corners.astype(np.float32), target)
    rect = cv2.warpPerspective(image, homography, (out_w, out_h), flags=cv2.INTER_LINEAR)

    # 5. leaves by HSV, small components removed, heights corrected
    hsv = cv2.cvtColor(rect, cv2.COLOR_RGB2HSV)
    lo = np.array([th.hue[0], th.min_saturation, th.min_value], dtype=np.uint8)
    hi = np.array([th.hue[1], 255, 255], dtype=np.uint8)
    leaves_raw = cv2.inRange(hsv, lo, hi)
    n, labels, stats, _ = cv2.connectedComponentsWithStats(leaves_raw, connectivity=8)
    big = stats[:, cv2.CC_STAT_AREA] >= th.min_component_mm2 * s * s
    big[0] = False
    leaves_clean = (big[labels]).astype(np.uint8) * 255
    nadir = cv2.perspectiveTransform(np.float32([[[w / 2, h / 2]]]), homography)[0, 0]
    k = (mount.height_mm - mount.leaf_height_mm) / mount.height_mm
    shrink = np.float32([[k, 0, (1 - k) * nadir[0]], [0, k, (1 - k) * nadir[1]]])
    leaves = cv2.warpAffine(leaves_clean, shrink, (out_w, out_h), flags=cv2.INTER_NEAREST)

    # 4. walls: the band on the rectified picture minus leaves, eroded and opened; profiles
    rect_norm = cv2.cvtColor(rect, cv2.COLOR_RGB2GRAY).astype(np.float32) / white
    walls = _band(rect_norm, th)
    walls[cv2.dilate(leaves_raw, _kernel(3)) > 0] = 0
    # erosion (the paper's), then the same dilation so that the walls' edges stay in place;
    # then an opening with a larger disc: perlite grains and crumbs go
    walls = cv2.dilate(cv2.erode(walls, _kernel(th.erode_mm * s)), _kernel(th.erode_mm * s))
    walls = cv2.morphologyEx(walls, cv2.MORPH_OPEN, _kernel(th.open_mm * s))
    wall01 = walls.astype(np.float32) / 255
    margin_x, margin_y = out_w // 20, out_h // 20
    col_profile = wall01[margin_y : out_h - margin_y].mean(axis=0)
    row_profile = wall01[:, margin_x : out_w - margin_x].mean(axis=1)
    cols = _openings(col_profile, layout.cols, th.profile_level, "column")
    rows = _openings(row_profile, layout.rows, th.profile_level, "row")
    col_borders = [(a - 0.5, b + 0.5) for a, b in cols]
    row_borders = [(a - 0.5, b + 0.5) for a, b in rows]

    # 6. per cell
    col_c = np.array([(a + b) / 2 for a, b in col_borders])
    row_c = np.array([(a + b) / 2 for a, b in row_borders])
    pitch_x = float(np.median(np.diff(col_c)))
    pitch_y = float(np.median(np.diff(row_c)))
    core_r = th.core_radius_mm * s
    cells: list[CellGrade] = []
    for r in range(layout.rows):
        for c in range(layout.cols):
            x0 = max(round(col_c[c] - pitch_x / 2), 0)
            x1 = min(round(col_c[c] + pitch_x / 2), out_w)
            y0 = max(round(row_c[r] - pitch_y / 2), 0)
            y1 = min(round(row_c[r] + pitch_y / 2), out_h)
            area, offset, lr, ud, reach_lr, reach_ud = _measure_cell(
                leaves[y0:y1, x0:x1],
                (col_c[c] - x0, row_c[r] - y0),
                (col_borders[c][0] - x0, col_borders[c][1] - x0),
                (row_borders[r][0] - y0, row_borders[r][1] - y0),
                s,
                core_r,
            )
            cells.append(
                CellGrade(
                    index=r * layout.cols + c,
                    row=r,
                    col=c,
                    grade=grade(area, offset, lr, ud, th.rule),
                    area_mm2=area,
                    centroid_offset_mm=offset,
                    secant_lr_mm=lr,
                    secant_ud_mm=ud,
                    centre_px=(float(col_c[c]), float(row_c[r])),
                    reach_lr_mm=reach_lr,
                    reach_ud_mm=reach_ud,
                )
            )
    seconds = time.perf_counter() - t0
    if keep_stages:
        stages = {
            "band": band,
            "frame": frame,
            "rectified": rect,
            "walls": walls,
            "leaves_raw": leaves_raw,
            "leaves": leaves,
            "col_profile": col_profile,
            "row_profile": row_profile,
        }
    return TrayGrading(cells, col_borders, row_borders, tilt_deg, s, seconds, rect, stages)
