"""The delta host's grading map (transplanter.twin.delta_grading) and what a misgraded cell costs
the cull-and-refill job through the physics (transplanter.twin.delta_refill): a healthy seedling
culled, an inferior one left, a refill let go on top of a plug, the claws at an empty cell, a
leaf torn at the setting a wrong grade gave.

The physics runs take a grading map made from the truth with some cells changed (no picture:
no GL needed). The pipeline's own map is tested through `transplanter trial` in a subprocess
with MUJOCO_GL=egl (osmesa if EGL cannot make a context), skipped without offscreen GL; a
trial without a GL context fails naming MUJOCO_GL and the truth alternative."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from dataclasses import replace

import pytest

from transplanter.scenario.schema import ScenarioError, load_scenario
from transplanter.scene.plug_tray import draw_tray
from transplanter.twin.delta_grading import (
    CellGrading,
    from_truth,
    leaf_extents_mm,
    truth_grades,
)
from transplanter.twin.delta_refill import MISGRADES, plan_job, rotary_for, run_delta_refill

SEED = 10  # planting 0-2 healthy, 3 inferior, 4 healthy, 92 the first empty; supply 0 healthy_lr,
# 8 the first empty
OFFSET = 1000003
SMALL = {"delta_refill.max_cells": 1, "delta_refill.image_delay_ms": 0.0,
         "delta_refill.vision": "truth"}  # fmt: skip
SETS = ["--set", "delta_refill.max_cells=1", "--set", "delta_refill.image_delay_ms=0"]


def _scenario(**over):
    return load_scenario("delta_refill", {**SMALL, **over})


def _trays():
    return draw_tray(SEED), draw_tray(SEED + OFFSET)


def _map(planting_grades: dict[int, str], supply_grades: dict[int, str]):
    """The truth's map with some cells' classes changed."""
    planting, supply = _trays()
    grades = from_truth(planting, supply)
    for tray, changes in ((grades.planting, planting_grades), (grades.supply, supply_grades)):
        for i, grade in changes.items():
            tray.cells[i] = replace(tray.cells[i], grade=grade)
    return grades


def test_the_vision_key_defaults_to_the_pipeline_and_takes_two_values():
    assert load_scenario("delta_refill").delta_refill.vision == "pipeline"
    assert load_scenario("paper").delta_refill.vision == "pipeline"  # the section's default
    assert _scenario().delta_refill.vision == "truth"
    with pytest.raises(ScenarioError, match="not one of pipeline, truth"):
        load_scenario("delta_refill", {"delta_refill.vision": "camera"})


def test_the_truth_map_is_the_drawn_classes_and_the_blades_reach():
    planting, supply = _trays()
    grades = from_truth(planting, supply)
    assert grades.source == "truth"
    assert grades.planting.classes() == planting.classes()
    assert grades.supply.classes() == supply.classes()
    c = supply.cells[3]  # healthy, inside its cell
    assert c.truth == "healthy"
    g = grades.supply.cells[3]
    assert (g.reach_lr_mm, g.reach_ud_mm) == leaf_extents_mm(c, supply.geometry)
    summary = grades.summary(planting, supply)
    assert summary["planting"]["correct"] == 128 and summary["supply"]["correct"] == 128


def test_the_rotary_setting_follows_the_grade():
    assert rotary_for(CellGrading("healthy_lr"), True, 0.0) == 90.0
    assert rotary_for(CellGrading("healthy_ud"), True, 0.0) == 0.0
    assert rotary_for(CellGrading("healthy", 9.0, 7.5), True, 0.0) == 90.0
    assert rotary_for(CellGrading("healthy", 7.5, 9.0), True, 0.0) == 0.0
    assert rotary_for(CellGrading("healthy_lr"), False, 45.0) == 45.0
    assert rotary_for(None, True, 45.0) == 45.0
    # the truth's map gives what the drawn leaves give
    supply = draw_tray(SEED + OFFSET)
    truth = truth_grades(supply)
    assert rotary_for(truth.cells[0], True, 0.0) == 90.0  # healthy_lr


def test_the_job_is_planned_from_the_map_not_the_truth():
    planting, supply = _trays()
    sc = load_scenario("delta_refill", {"delta_refill.max_cells": 2})
    assert [(o.cell, o.supply, o.rotary_deg) for o in plan_job(sc, planting, supply)] == [
        (3, 0, 90.0),
        (5, 1, 90.0),
    ]
    grades = _map({3: "healthy", 4: "inferior"}, {0: "inferior", 1: "healthy_ud"})
    ops = plan_job(sc, planting, supply, grades)
    assert [(o.cell, o.truth, o.supply, o.rotary_deg) for o in ops] == [
        (4, "inferior", 1, 0.0),
        (5, "inferior", 2, 90.0),
    ]


def test_a_healthy_seedling_graded_inferior_is_culled_and_a_wrong_pose_tears_a_leaf():
    grades = _map({3: "healthy", 4: "inferior"}, {0: "healthy_ud"})
    r = run_delta_refill(_scenario(), SEED, grades=grades)
    (cell,) = r.cells
    assert (cell.index, cell.grade, cell.truth) == (4, "inferior", "healthy")
    assert cell.culled == "binned"  # the healthy seedling went to the bin
    assert (cell.supply_index, cell.supply_grade, cell.supply_truth) == (
        0,
        "healthy_ud",
        "healthy_lr",
    )
    assert (cell.rotary_deg, cell.rotary_truth_deg) == (0.0, 90.0)
    assert cell.refilled == "seated" and cell.leaf_damage
    assert cell.misgrades == ["healthy_culled", "orientation_damage"]
    assert r.failures["misgrade_healthy_culled"] == 1
    assert r.failures["misgrade_orientation_damage"] == 1
    assert r.failures["misgrade_inferior_left"] == 1  # cell 3, passed over before cell 4
    assert r.successes == 0 and r.leaf_damage_rate == 1.0
    d = r.to_dict()
    assert d["cells"][0]["grade"] == "inferior" and d["cells"][0]["truth"] == "healthy"
    assert {m["kind"] for m in d["misgraded"]} == {
        "healthy_culled",
        "orientation_damage",
        "inferior_left",
    }
    assert d["vision"] == "truth" and d["grading"]["planting"]["correct"] == 126
    assert d["grading"]["planting"]["confusion"][1][4] == 1  # an inferior graded healthy
    assert set(MISGRADES) >= {m["kind"] for m in d["misgraded"]}


def test_a_seedling_graded_empty_gets_a_refill_on_top_of_its_plug():
    grades = _map({0: "empty"}, {})
    r = run_delta_refill(_scenario(), SEED, grades=grades)
    (cell,) = r.cells
    assert (cell.index, cell.grade, cell.truth) == (0, "empty", "healthy")
    # the refill brought down over the cell meets the plug still in it, shears off the pins
    # and stays wedged against the stripper: it rides in the head to the home pose
    assert cell.culled is None and cell.refilled == "jammed" and cell.retention is None
    assert cell.misgrades == ["refill_on_plug"]
    assert r.failures["misgrade_refill_on_plug"] == 1 and r.failures["refill_jammed"] == 1
    assert r.dropped == 1
    assert r.fault is None


def test_an_empty_cell_graded_inferior_and_an_empty_supply_cell_graded_healthy():
    planting, _ = _trays()
    before = {i: "healthy" for i in range(92) if planting.cells[i].truth == "inferior"}
    grades = _map({**before, 92: "inferior"}, {**{i: "inferior" for i in range(8)}, 8: "healthy"})
    r = run_delta_refill(_scenario(), SEED, grades=grades)
    (cell,) = r.cells
    assert (cell.index, cell.truth, cell.supply_index, cell.supply_truth) == (
        92,
        "empty",
        8,
        "empty",
    )
    assert cell.culled == "nothing" and cell.refilled == "nothing_picked"
    assert cell.misgrades == ["empty_culled", "empty_picked"]
    assert r.failures["misgrade_inferior_left"] == len(before) == 15
    assert r.failures["misgrade_empty_culled"] == 1 and r.failures["misgrade_empty_picked"] == 1
    assert r.leaf_damage_rate == 0.0 and r.fault is None  # no seedling was picked


def _env(gl: str) -> dict[str, str]:
    env = {k: v for k, v in os.environ.items() if k not in ("DISPLAY", "WAYLAND_DISPLAY")}
    env["MUJOCO_GL"] = gl
    return env


def _trial(*extra: str, gl: str | None = None) -> subprocess.CompletedProcess:
    """`transplanter trial delta_refill` in a subprocess: with `gl`, that backend; else EGL,
    then OSMesa, skipping the test when neither makes a context."""
    cmd = [sys.executable, "-m", "transplanter.cli", "trial", "delta_refill", "--seed",
           str(SEED), *SETS, *extra]  # fmt: skip
    if gl is not None:
        return subprocess.run(cmd, capture_output=True, text=True, env=_env(gl), timeout=600)
    run = None
    for backend in ("egl", "osmesa"):
        run = subprocess.run(cmd, capture_output=True, text=True, env=_env(backend), timeout=600)
        if run.returncode == 0 or "OpenGL" not in run.stderr:
            return run
    pytest.skip(f"no offscreen OpenGL here (egl, osmesa): {run.stderr.strip()[-300:]}")


def test_without_a_gl_context_the_pipeline_trial_fails_naming_both_ways_out(tmp_path):
    out = tmp_path / "r.json"
    run = _trial("--json", str(out), gl="glfw")  # GLFW needs a display: none here
    assert run.returncode == 2, run.stderr
    assert "no OpenGL context" in run.stderr and "MUJOCO_GL=egl" in run.stderr
    assert "--set delta_refill.vision=truth" in run.stderr
    assert not out.exists()


def test_the_pipeline_grades_both_trays_and_drives_the_job(tmp_path):
    out = tmp_path / "r.json"
    run = _trial("--json", str(out))
    assert run.returncode == 0, run.stderr
    d = json.loads(out.read_text())
    assert d["vision"] == "pipeline"
    g = d["grading"]
    assert g["source"] == "pipeline" and g["picture_px"] == [1600, 900]
    for tray in ("planting", "supply"):
        assert g[tray]["cells"] == 128 and g[tray]["correct"] >= 122  # >= 95 %
        assert 0 < g[tray]["recognition_wall_s"] < 10 and g[tray]["render_wall_s"] > 0
    (cell,) = d["cells"]
    assert (cell["index"], cell["grade"], cell["truth"]) == (3, "inferior", "inferior")
    assert (cell["supply_grade"], cell["supply_truth"]) == ("healthy_lr", "healthy_lr")
    assert cell["rotary_deg"] == cell["rotary_truth_deg"] == 90.0
    assert cell["culled"] == "binned" and cell["refilled"] == "seated"
    assert "graded by the pipeline: planting" in run.stdout


def test_a_picture_the_pipeline_cannot_read_gives_a_named_error_not_a_job(tmp_path):
    out = tmp_path / "r.json"
    run = _trial("--json", str(out), "--set", "vision.min_contrast=200")
    assert run.returncode == 2, run.stderr
    assert "the planting tray's picture (seed 10) cannot be graded" in run.stderr
    assert "ImageUnusable: blank picture" in run.stderr
    assert not out.exists()
