"""The 128-cell plug tray as data (transplanter.scene.plug_tray): truth classes follow the paper's
thresholds on hand-made seedlings, the draw is deterministic, and the plug_trays workcell's
files and MjSpec builder hold what the draw asks for (no rendering here: tests/test_vision.py)."""

from __future__ import annotations

import math
import subprocess
import sys

import mujoco
import pytest

from conftest import ROOT
from transplanter.scene.plug_tray import (
    Leaf,
    Seedling,
    SeedlingDraw,
    TrayGeometry,
    draw_tray,
    measure,
)
from transplanter.scene.tray_camera import build_spec, draw_appearance
from transplanter.vision.grading import CLASSES, GradingRule, grade

G = TrayGeometry()


def leaf(stem, angle_deg, radial, tangential, petiole=1.0, height=12.0) -> Leaf:
    a = math.radians(angle_deg)
    c, s = math.cos(a), math.sin(a)
    base = (stem[0] + petiole * c, stem[1] + petiole * s)
    return Leaf(
        cx=base[0] + radial * c,
        cy=base[1] + radial * s,
        radial_mm=radial,
        tangential_mm=tangential,
        angle_rad=a,
        height_mm=height,
        base=base,
        petiole_radius_mm=0.5,
    )


def seedling(stem, *leaves) -> Seedling:
    return Seedling(stem=stem, leaves=leaves, hub_radius_mm=1.0, stem_radius_mm=0.8)


def classify(s: Seedling | None, centre=(0.0, 0.0)) -> tuple[str, tuple]:
    m = measure(s, centre, G)
    return grade(*m), m


def test_the_rule_at_its_thresholds():
    rule = GradingRule()
    assert grade(0.0, 0.0, 0.0, 0.0) == "empty"
    assert grade(rule.empty_area_mm2 - 0.1, 0, 0, 0) == "empty"
    assert grade(99.9, 0, 0, 0) == "inferior"
    assert grade(100.0, 0, 0, 0) == "healthy"
    assert grade(300, 10.0, 0, 0) == "healthy"
    assert grade(300, 10.1, 20, 0) == "inferior"  # off-centre beats crossing
    assert grade(300, 2, 12.0, 0) == "healthy"  # over 12 mm, not at 12
    assert grade(300, 2, 12.1, 0) == "healthy_lr"
    assert grade(300, 2, 0, 12.1) == "healthy_ud"
    assert grade(300, 2, 14, 13) == "healthy_lr"  # the longer secant names it
    assert grade(300, 2, 13, 14) == "healthy_ud"
    assert grade(80, 0, 0, 0, GradingRule(min_leaf_area_mm2=50)) == "healthy"


def test_an_empty_cell_is_empty():
    assert classify(None)[0] == "empty"


def test_two_blades_inside_the_cell_are_healthy_and_measured():
    s = seedling((0.0, 0.0), leaf((0, 0), 30, 5, 6), leaf((0, 0), 210, 5, 6))
    cls, (area, offset, lr, ud) = classify(s)
    blades = 2 * math.pi * 5 * 6
    assert cls == "healthy"
    assert blades < area < blades + 15  # plus hub and petioles
    assert offset < 0.2 and lr == 0.0 and ud == 0.0


def test_small_leaves_are_inferior():
    s = seedling((0.0, 0.0), leaf((0, 0), 0, 3, 4), leaf((0, 0), 180, 3, 4))
    cls, (area, *_) = classify(s)
    assert cls == "inferior" and area < 100


def test_a_blade_over_the_right_border_crosses_left_right():
    # blade centre 11 mm right of the stem, 7 mm radial: its edge 3 mm past the 15 mm border;
    # its chord there 2 * 10 * sqrt(1 - (4/7)^2) = 16.4 mm
    s = seedling((0.0, 0.0), leaf((0, 0), 0, 7, 10, petiole=4), leaf((0, 0), 180, 5, 6))
    cls, (area, offset, lr, ud) = classify(s)
    assert cls == "healthy_lr"
    assert lr == pytest.approx(2 * 10 * math.sqrt(1 - (4 / 7) ** 2), abs=0.5)
    assert ud == 0.0


def test_a_blade_over_the_upper_border_crosses_up_down_in_any_cell():
    centre = G.centre(2, 5)
    stem = centre
    s = seedling(stem, leaf(stem, 90, 7, 10, petiole=4), leaf(stem, 270, 5, 6))
    cls, (area, offset, lr, ud) = classify(s, centre)
    assert cls == "healthy_ud" and ud > 12 and lr == 0.0


def test_a_short_secant_is_not_a_crossing():
    # the blade's edge 1 mm past the border: chord 2 * 6 * sqrt(1 - (6/7)^2) = 6.2 mm
    s = seedling((0.0, 0.0), leaf((0, 0), 0, 7, 6, petiole=2), leaf((0, 0), 180, 5, 6))
    cls, (area, offset, lr, ud) = classify(s)
    assert cls == "healthy" and 0 < lr < 12


def test_a_seedling_near_the_corner_is_inferior():
    stem = (9.0, 9.0)
    s = seedling(stem, leaf(stem, 30, 5, 6), leaf(stem, 60, 5, 6))
    cls, (area, offset, *_) = classify(s)
    assert area > 100 and offset > 10 and cls == "inferior"


def test_the_draw_is_deterministic_and_seeds_differ():
    a, b, c = draw_tray(11), draw_tray(11), draw_tray(12)
    assert a == b
    assert a.classes() != c.classes() or a.cells != c.cells
    assert len(a.cells) == 128 and {x.index for x in a.cells} == set(range(128))
    assert set(a.classes()) <= set(CLASSES)
    assert draw_appearance(11) == draw_appearance(11) != draw_appearance(12)


def test_the_drawn_kinds_land_on_their_side_of_the_thresholds():
    expect = {
        "empty": {"empty"},
        "small": {"inferior"},
        "off_centre": {"inferior"},
        "cross_lr": {"healthy_lr"},
        "cross_ud": {"healthy_ud"},
        "inside": {"healthy"},
    }
    for seed in (0, 1):
        for cell in draw_tray(seed).cells:
            assert cell.truth in expect[cell.kind], cell


def test_probabilities_must_make_sense():
    with pytest.raises(ValueError, match="sum to <= 1"):
        draw_tray(0, SeedlingDraw(p_empty=0.6, p_small=0.6))
    only_empty = draw_tray(0, SeedlingDraw(p_empty=1.0, p_small=0, p_off_centre=0,
                                           p_cross_lr=0, p_cross_ud=0))  # fmt: skip
    assert set(only_empty.classes()) == {"empty"}


def test_the_workcell_files_are_up_to_date():
    run = subprocess.run(
        [sys.executable, str(ROOT / "scripts" / "make_plug_trays_model.py"), "--check"],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert run.returncode == 0, run.stdout + run.stderr


def test_the_builder_adds_every_drawn_leaf_and_substrate_to_the_tray():
    tray = draw_tray(3)
    spec = build_spec(tray, draw_appearance(3))
    model = spec.compile()
    names = [model.geom(i).name for i in range(model.ngeom)]
    leaves = sum(len(c.seedling.leaves) for c in tray.cells if c.seedling is not None)
    assert sum(n.startswith("leaf_") for n in names) == leaves
    assert sum(n.startswith("substrate_") for n in names) == 128
    assert mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_CAMERA, "tray_camera") >= 0
    tray_body = model.body("tray").id
    assert all(model.geom_bodyid[i] == tray_body for i, n in enumerate(names) if "leaf" in n)
