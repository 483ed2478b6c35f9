"""A 128-cell plug tray and the seedlings in its cells, as data: pure numpy, drawn from a seed.

The tray is seed 002's (Zhao et al. 2022, Sec. 2.1): 566 x 286 mm, 8 rows x 16 columns, cells
30 x 30 mm at the top and 20 x 20 mm at the bottom, 42 mm deep. Tray frame: millimetres, origin
at the centre of the tray's top face, x along the 566 mm length (columns), y along the width
(rows; row 0 at +y, the top of the camera's picture), z up (0 = the top of the walls). Cell
(row, col) has index row * cols + col.

Each cell is drawn as one of the kinds of `SeedlingDraw` (empty, a small seedling, one standing
off-centre, a seedling whose leaves cross the left/right or the upper/lower border, one that
stays inside); its leaves are ellipses (blades) on capsules (petioles) around a stem, each with
its height above the tray. The ground truth class of a cell is computed from the drawn leaves by
the paper's rule (`transplanter.vision.grading`), not taken from the kind that was drawn: a
drawn kind near a threshold may land on the other side of it.

No MuJoCo here (`transplanter.scene.tray_camera` turns a draw into geoms).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from transplanter.vision.grading import (
    EMPTY,
    GradingRule,
    grade,
)

# Raster step (mm) of the exact measurement of a seedling's leaves: the truth.
TRUTH_STEP_MM = 0.2


@dataclass(frozen=True)
class TrayGeometry:
    """The tray. From the paper: length, width, rows x cols, top and bottom openings, depth.
    Estimates (the paper gives none): the pitch of 34 mm (walls 4 mm wide at the top; the rim
    is what is left: 11 mm at the ends, 7 mm at the sides) and the substrate surface 3 mm
    below the top of the walls."""

    rows: int = 8
    cols: int = 16
    length_mm: float = 566.0
    width_mm: float = 286.0
    opening_mm: float = 30.0
    bottom_opening_mm: float = 20.0
    depth_mm: float = 42.0
    pitch_mm: float = 34.0
    substrate_below_top_mm: float = 3.0

    @property
    def cells(self) -> int:
        return self.rows * self.cols

    def centre(self, row: int, col: int) -> tuple[float, float]:
        """The centre of a cell in the tray frame (mm)."""
        return (
            (col - (self.cols - 1) / 2) * self.pitch_mm,
            ((self.rows - 1) / 2 - row) * self.pitch_mm,
        )

    def centres(self) -> np.ndarray:
        """(cells, 2) centres in index order (row-major)."""
        return np.array([self.centre(i // self.cols, i % self.cols) for i in range(self.cells)])


@dataclass(frozen=True)
class SeedlingDraw:
    """What a tray's cells hold and how their leaves are drawn. All numbers are this project's
    estimates for 10- to 25-day broccoli plug seedlings (2-3 leaves, no leaves of neighbours
    overlapping, as the paper describes its trays), chosen so that every kind lies clearly on
    its side of the paper's thresholds: the paper gives no distributions.

    The kinds' probabilities (the rest, `1 - sum`, is healthy and inside its cell) and, per
    kind, the blade's semi-axes along the petiole (`radial`) and across it (`tangential`)."""

    p_empty: float = 0.06
    p_small: float = 0.10
    p_off_centre: float = 0.04
    p_cross_lr: float = 0.15
    p_cross_ud: float = 0.15
    # healthy, inside the cell: two opposite cotyledons, a third (true) leaf with p_third_leaf
    radial_mm: tuple[float, float] = (4.0, 5.5)
    tangential_mm: tuple[float, float] = (5.0, 7.0)
    petiole_mm: tuple[float, float] = (1.0, 2.5)
    p_third_leaf: float = 0.4
    third_leaf_scale: tuple[float, float] = (0.5, 0.75)
    # crossing: the crossing blade's far edge lies this far beyond the border (mm); its
    # opposite cotyledon crosses too with p_both_cross
    overhang_mm: tuple[float, float] = (3.0, 3.8)
    cross_radial_mm: tuple[float, float] = (5.5, 7.0)
    cross_tangential_mm: tuple[float, float] = (9.0, 11.0)
    cross_angle_deg: float = 8.0
    p_both_cross: float = 0.3
    # small (inferior) seedlings: total leaf area drawn in this range (mm^2)
    small_area_mm2: tuple[float, float] = (25.0, 70.0)
    # off-centre seedlings: stem this far from the centre along a diagonal, leaves leaning out
    off_centre_mm: tuple[float, float] = (8.0, 10.0)
    # every seedling
    stem_offset_mm: float = 1.5
    stem_radius_mm: float = 0.8
    hub_radius_mm: float = 1.2
    petiole_radius_mm: float = 0.6
    leaf_height_mm: tuple[float, float] = (8.0, 20.0)
    # moss specks on the substrate (removed as small components) and perlite grains
    specks_per_cell: float = 0.3
    speck_radius_mm: tuple[float, float] = (0.5, 1.0)
    perlite_per_cell: float = 4.0
    perlite_radius_mm: tuple[float, float] = (0.6, 1.1)

    @staticmethod
    def near_thresholds() -> SeedlingDraw:
        """A harder draw for measuring the pipeline, not a tray: small seedlings' leaf areas
        spread across 100 mm^2 (60-140), off-centre stems across the 10 mm centroid limit
        (5-11 mm) and crossing blades from barely past the border to well past it (0.5-4 mm,
        secants from about 5 to 17 mm, across 12 mm)."""
        return SeedlingDraw(
            small_area_mm2=(60.0, 140.0),
            off_centre_mm=(5.0, 11.0),
            overhang_mm=(0.5, 4.0),
        )

    def probabilities(self) -> dict[str, float]:
        named = {
            "empty": self.p_empty,
            "small": self.p_small,
            "off_centre": self.p_off_centre,
            "cross_lr": self.p_cross_lr,
            "cross_ud": self.p_cross_ud,
        }
        rest = 1.0 - sum(named.values())
        if rest < -1e-12 or any(p < 0 for p in named.values()):
            raise ValueError(f"the kinds' probabilities must be >= 0 and sum to <= 1: {named}")
        return {**named, "inside": max(rest, 0.0)}


@dataclass(frozen=True)
class Leaf:
    """One leaf seen from above: an elliptic blade (centre, semi-axis `radial_mm` along
    `angle_rad`, the petiole's direction, `tangential_mm` across it) on a petiole, a capsule of
    radius `petiole_radius_mm` from the stem to the blade's base, `height_mm` above the tray
    top. Tray frame, mm."""

    cx: float
    cy: float
    radial_mm: float
    tangential_mm: float
    angle_rad: float
    height_mm: float
    base: tuple[float, float]
    petiole_radius_mm: float

    @property
    def blade_area_mm2(self) -> float:
        return math.pi * self.radial_mm * self.tangential_mm


@dataclass(frozen=True)
class Seedling:
    """A seedling in its cell: the stem (tray frame, mm) and its leaves."""

    stem: tuple[float, float]
    leaves: tuple[Leaf, ...]
    hub_radius_mm: float
    stem_radius_mm: float

    def inside(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """Whether points (tray frame, mm) lie under a leaf, a petiole or the stem's hub, seen
        from above."""
        sx, sy = self.stem
        hit = (x - sx) ** 2 + (y - sy) ** 2 <= self.hub_radius_mm**2
        for leaf in self.leaves:
            c, s = math.cos(leaf.angle_rad), math.sin(leaf.angle_rad)
            dx, dy = x - leaf.cx, y - leaf.cy
            u, v = dx * c + dy * s, -dx * s + dy * c
            hit |= (u / leaf.radial_mm) ** 2 + (v / leaf.tangential_mm) ** 2 <= 1.0
            hit |= _in_capsule(x, y, self.stem, leaf.base, leaf.petiole_radius_mm)
        return hit


def _in_capsule(x, y, a, b, r) -> np.ndarray:
    ax, ay = a
    bx, by = b
    vx, vy = bx - ax, by - ay
    n2 = vx * vx + vy * vy
    t = np.clip(((x - ax) * vx + (y - ay) * vy) / n2, 0.0, 1.0) if n2 > 0 else 0.0
    return (x - ax - t * vx) ** 2 + (y - ay - t * vy) ** 2 <= r * r


@dataclass(frozen=True)
class Speck:
    """A moss speck (green) or a perlite grain (white) on a cell's substrate: tray frame, mm."""

    x: float
    y: float
    radius_mm: float
    kind: str  # "moss" or "perlite"


@dataclass(frozen=True)
class CellTruth:
    """What a cell holds and its class by the paper's rule, measured on the drawn leaves."""

    index: int
    row: int
    col: int
    kind: str
    seedling: Seedling | None
    area_mm2: float
    centroid_offset_mm: float
    secant_lr_mm: float
    secant_ud_mm: float
    truth: str

    def as_dict(self) -> dict:
        return {
            "index": self.index,
            "row": self.row,
            "col": self.col,
            "kind": self.kind,
            "truth": self.truth,
            "area_mm2": round(self.area_mm2, 2),
            "centroid_offset_mm": round(self.centroid_offset_mm, 2),
            "secant_lr_mm": round(self.secant_lr_mm, 2),
            "secant_ud_mm": round(self.secant_ud_mm, 2),
        }


@dataclass(frozen=True)
class TrayDraw:
    """A drawn tray: its geometry, the cells (index order) and the specks on the substrate."""

    seed: int
    geometry: TrayGeometry
    cells: tuple[CellTruth, ...]
    specks: tuple[Speck, ...]
    rule: GradingRule = field(default_factory=GradingRule)

    def classes(self) -> list[str]:
        return [c.truth for c in self.cells]


def measure(
    seedling: Seedling | None,
    centre: tuple[float, float],
    geometry: TrayGeometry,
    step_mm: float = TRUTH_STEP_MM,
) -> tuple[float, float, float, float]:
    """(area mm^2, centroid offset from the cell centre mm, longest secant with the left or
    right border mm, longest with the upper or lower border mm) of a seedling's leaves seen
    from above, by rasterising them at `step_mm`. The borders are the cell's top opening; a
    secant is the length of the border line, within the cell's pitch square, under leaves."""
    if seedling is None:
        return 0.0, 0.0, 0.0, 0.0
    cx, cy = centre
    half = geometry.pitch_mm / 2 + 6.0
    xs = np.arange(cx - half, cx + half, step_mm) + step_mm / 2
    ys = np.arange(cy - half, cy + half, step_mm) + step_mm / 2
    gx, gy = np.meshgrid(xs, ys)
    hit = seedling.inside(gx, gy)
    area = float(hit.sum()) * step_mm * step_mm
    if area == 0.0:
        return 0.0, 0.0, 0.0, 0.0
    offset = float(math.hypot(gx[hit].mean() - cx, gy[hit].mean() - cy))
    border = geometry.opening_mm / 2
    span = np.arange(-geometry.pitch_mm / 2, geometry.pitch_mm / 2, step_mm) + step_mm / 2
    secants = []
    for dx, dy in ((-border, None), (border, None), (None, -border), (None, border)):
        if dx is not None:
            on = seedling.inside(np.full_like(span, cx + dx), cy + span)
        else:
            on = seedling.inside(cx + span, np.full_like(span, cy + dy))
        secants.append(float(on.sum()) * step_mm)
    return area, offset, max(secants[0], secants[1]), max(secants[2], secants[3])


def _u(rng: np.random.Generator, lo_hi: tuple[float, float]) -> float:
    return float(rng.uniform(*lo_hi))


def _leaf(
    rng: np.random.Generator,
    stem: tuple[float, float],
    angle: float,
    radial: float,
    tangential: float,
    petiole: float,
    draw: SeedlingDraw,
) -> Leaf:
    c, s = math.cos(angle), math.sin(angle)
    base = (stem[0] + petiole * c, stem[1] + petiole * s)
    centre = (base[0] + radial * c, base[1] + radial * s)
    return Leaf(
        cx=centre[0],
        cy=centre[1],
        radial_mm=radial,
        tangential_mm=tangential,
        angle_rad=angle,
        height_mm=_u(rng, draw.leaf_height_mm),
        base=base,
        petiole_radius_mm=draw.petiole_radius_mm,
    )


def _typical_leaf(
    rng: np.random.Generator, stem: tuple[float, float], angle: float, draw: SeedlingDraw
) -> Leaf:
    """A leaf of the draw's usual size (radial, tangential and petiole drawn in that order)."""
    radial = _u(rng, draw.radial_mm)
    tangential = _u(rng, draw.tangential_mm)
    petiole = _u(rng, draw.petiole_mm)
    return _leaf(rng, stem, angle, radial, tangential, petiole, draw)


def _seedling(
    rng: np.random.Generator,
    kind: str,
    centre: tuple[float, float],
    geometry: TrayGeometry,
    draw: SeedlingDraw,
) -> Seedling | None:
    if kind == "empty":
        return None
    cx, cy = centre
    r = draw.stem_offset_mm * math.sqrt(rng.uniform())
    phi = rng.uniform(0, 2 * math.pi)
    stem = (cx + r * math.cos(phi), cy + r * math.sin(phi))
    leaves: list[Leaf] = []
    if kind == "small":
        n = int(rng.integers(1, 3))
        total = _u(rng, draw.small_area_mm2)
        theta0 = rng.uniform(0, 2 * math.pi)
        for k in range(n):
            area = total / n
            aspect = rng.uniform(0.7, 1.3)
            radial = math.sqrt(area / math.pi * aspect)
            tangential = area / (math.pi * radial)
            angle = theta0 + k * math.pi + rng.normal(0, 0.2)
            leaves.append(_leaf(rng, stem, angle, radial, tangential, 0.8, draw))
    elif kind == "off_centre":
        diag = rng.integers(0, 4) * math.pi / 2 + math.pi / 4
        d = _u(rng, draw.off_centre_mm)
        stem = (cx + d * math.cos(diag), cy + d * math.sin(diag))
        for k in range(2):
            angle = diag + (k - 0.5) * rng.uniform(0.6, 1.2)
            leaves.append(_typical_leaf(rng, stem, angle, draw))
    elif kind in ("cross_lr", "cross_ud"):
        axis = 0.0 if kind == "cross_lr" else math.pi / 2
        side = float(rng.choice([0.0, math.pi]))
        border = geometry.opening_mm / 2
        both = rng.uniform() < draw.p_both_cross
        for k in range(2):
            angle = (
                axis + side + k * math.pi + math.radians(rng.uniform(-1, 1) * draw.cross_angle_deg)
            )
            if k == 0 or both:
                radial = _u(rng, draw.cross_radial_mm)
                tangential = _u(rng, draw.cross_tangential_mm)
                # the blade's far edge `overhang` beyond the border, along its direction
                direction = np.array([math.cos(angle), math.sin(angle)])
                along = float(np.dot(np.array(stem) - np.array(centre), direction))
                reach = (border + _u(rng, draw.overhang_mm)) / max(
                    abs(math.cos(angle - axis - side - k * math.pi)), 0.5
                )
                petiole = max(reach - along - 2 * radial, 0.5)
            else:
                radial = _u(rng, draw.radial_mm)
                tangential = _u(rng, draw.tangential_mm)
                petiole = _u(rng, draw.petiole_mm)
            leaves.append(_leaf(rng, stem, angle, radial, tangential, petiole, draw))
    else:  # inside
        theta0 = rng.uniform(0, 2 * math.pi)
        for k in range(2):
            angle = theta0 + k * math.pi + rng.normal(0, 0.15)
            leaves.append(_typical_leaf(rng, stem, angle, draw))
        if rng.uniform() < draw.p_third_leaf:
            scale = _u(rng, draw.third_leaf_scale)
            leaves.append(
                _leaf(
                    rng,
                    stem,
                    theta0 + math.pi / 2 + rng.choice([0.0, math.pi]),
                    _u(rng, draw.radial_mm) * scale,
                    _u(rng, draw.tangential_mm) * scale,
                    _u(rng, draw.petiole_mm),
                    draw,
                )
            )
    return Seedling(
        stem=stem,
        leaves=tuple(leaves),
        hub_radius_mm=draw.hub_radius_mm,
        stem_radius_mm=draw.stem_radius_mm,
    )


def draw_tray(
    seed: int,
    draw: SeedlingDraw | None = None,
    geometry: TrayGeometry | None = None,
    rule: GradingRule | None = None,
) -> TrayDraw:
    """The cells of one tray drawn from `seed` (the same seed, the same tray), each with its
    truth class by `rule` (default: the paper's thresholds)."""
    draw = draw or SeedlingDraw()
    geometry = geometry or TrayGeometry()
    rule = rule or GradingRule()
    rng = np.random.default_rng(seed)
    probs = draw.probabilities()
    names = list(probs)
    p = np.array([probs[n] for n in names])
    kinds = rng.choice(len(names), size=geometry.cells, p=p / p.sum())
    cells = []
    for index in range(geometry.cells):
        row, col = divmod(index, geometry.cols)
        centre = geometry.centre(row, col)
        kind = names[int(kinds[index])]
        seedling = _seedling(rng, kind, centre, geometry, draw)
        area, offset, lr, ud = measure(seedling, centre, geometry)
        truth = grade(area, offset, lr, ud, rule) if seedling is not None else EMPTY
        cells.append(CellTruth(index, row, col, kind, seedling, area, offset, lr, ud, truth))
    specks = []
    half = geometry.opening_mm / 2 - 1.5
    for index in range(geometry.cells):
        cx, cy = geometry.centre(*divmod(index, geometry.cols))
        for kind, rate, radius in (
            ("moss", draw.specks_per_cell, draw.speck_radius_mm),
            ("perlite", draw.perlite_per_cell, draw.perlite_radius_mm),
        ):
            for _ in range(int(rng.poisson(rate))):
                x, y = rng.uniform(-half, half, size=2)
                specks.append(Speck(cx + float(x), cy + float(y), _u(rng, radius), kind))
    return TrayDraw(seed, geometry, tuple(cells), tuple(specks), rule)
