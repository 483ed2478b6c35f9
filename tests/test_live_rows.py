"""The window of live rows (transplanter.scene.live_rows): a long belt's pots as a few rows of
reused bodies."""

from __future__ import annotations

import dataclasses

import mujoco
import numpy as np
import pytest

from conftest import paper_config, paper_scenario
from transplanter.scenario.schema import ScenarioError
from transplanter.scene import ConveyorDrive, build_scene
from transplanter.scene.config import MIN_LIVE_ROWS, MIN_LIVE_ROWS_ON_FEET, SceneConfig, row_bit
from transplanter.scene.live_rows import (
    _BODY_FIELDS,
    _DOF_FIELDS,
    _FOOT_FIELDS,
    _GEOM_FIELDS,
    GONE,
    LIVE,
)
from transplanter.twin.results import Outcome
from transplanter.twin.sim import Twin
from transplanter.twin.trial import run_trial

# the pots on their cylinders and the PD index (the paper scenario: 8 feet, the stepper index)
CYLINDERS = {"pots.feet": 0, "conveyor.index_drive": "pd"}


def _pot_bodies(model: mujoco.MjModel) -> list[str]:
    return [model.body(b).name for b in range(model.nbody) if model.body(b).name.startswith("pot_")]


def test_a_30_row_belt_has_only_the_live_rows_as_bodies():
    scene = build_scene(SceneConfig(rows=30, live_rows=6), seed=3)
    assert len(_pot_bodies(scene.model)) == 6 * 5
    ribs = [b for b in range(scene.model.nbody) if scene.model.body(b).name.startswith("ribs_")]
    assert len(ribs) == 7  # one row of ribs more than rows of pots
    assert scene.pot_live.sum() == 30 and not scene.pot_live[30:].any()
    assert (scene.pot_bodies.ravel()[30:] == -1).all()
    # the pots of a seed are drawn for the whole belt, the same as with a body per pot
    assert scene.pots == build_scene(SceneConfig(rows=30, live_rows=30), seed=3).pots


def test_live_rows_covering_the_belt_build_the_scene_of_a_body_per_pot():
    windowless = build_scene(SceneConfig(rows=8, live_rows=8), seed=2)
    wide = build_scene(SceneConfig(rows=8, live_rows=400), seed=2)
    assert wide.window is None and windowless.window is None
    assert windowless.model.nbody == wide.model.nbody == 8 * 5 + windowless.model.nbody - 40
    for name in ("body_mass", "geom_size", "geom_pos", "body_pos", "geom_contype", "qpos0"):
        assert np.array_equal(getattr(windowless.model, name), getattr(wide.model, name)), name


@pytest.mark.parametrize("feet, live", [(0, 6), (8, 12)])
def test_an_entering_row_takes_the_fields_and_place_a_body_per_pot_has(feet, live):
    """Row `live` enters the slots row 0 leaves: each slot gets exactly the compiled fields of
    that pot's own body in a scene with a body per pot (its feet too, when the pots stand on
    feet: their ring follows the pot's radius, their height its base), and stands in its
    cell where the carriage has carried it."""
    rows = live + 4
    window_cfg = SceneConfig(rows=rows, live_rows=live, pot_soft_share=0.4, pot_feet=feet)
    scene = build_scene(window_cfg, seed=5)
    full = build_scene(dataclasses.replace(window_cfg, live_rows=rows), seed=5)
    data = scene.make_data()
    pitch = window_cfg.row_pitch_m
    data.qpos[scene.conveyor_qpos_adr] = -pitch  # one index done
    window = scene.window
    slots = scene.pot_bodies[0].copy()
    first = 5 * live  # the entering row's first pot
    for pot in range(5):  # the judge parks row 0's pots; row `live` takes their bodies
        window.release(data, pot)
    assert (window.state[:5] == GONE).all() and (window.state[first : first + 5] == LIVE).all()
    assert np.array_equal(scene.pot_bodies[live], slots) and (scene.pot_bodies[0] == -1).all()
    mujoco.mj_forward(scene.model, data)
    m, f = scene.model, full.model
    for c in range(5):
        body, fbody = scene.pot_bodies[live, c], f.body(f"pot_{live}_{c}").id
        for name in _BODY_FIELDS:
            assert np.array_equal(getattr(m, name)[body], getattr(f, name)[fbody]), name
        dof, fdof = scene.pot_dof_adr[first + c], full.pot_dof_adr[first + c]
        for name in _DOF_FIELDS:
            assert np.array_equal(
                getattr(m, name)[dof : dof + 6], getattr(f, name)[fdof : fdof + 6]
            )
        geom, fgeom = scene.pot_geoms[first + c], full.pot_geoms[first + c]
        for name in _GEOM_FIELDS:
            assert np.array_equal(getattr(m, name)[geom], getattr(f, name)[fgeom]), name
        assert m.geom_contype[geom] & row_bit(live)
        for k in range(feet):
            foot, ffoot = m.geom(f"foot_0_{c}_{k}").id, f.geom(f"foot_{live}_{c}_{k}").id
            assert m.geom_bodyid[foot] == body
            for name in _FOOT_FIELDS:
                assert np.array_equal(getattr(m, name)[foot], getattr(f, name)[ffoot]), name
        # its place: its cell and drawn offset, carried one row pitch
        start = f.qpos0[full.pot_qpos_adr[first + c] : full.pot_qpos_adr[first + c] + 3]
        assert np.allclose(data.xpos[body], start - [0, pitch, 0], atol=1e-12)
    assert np.allclose(scene.pot_positions(data)[first : first + 5],
                       data.xpos[scene.pot_bodies[live]])  # fmt: skip
    # the pots that left lie where they were; the waiting ones ride in their cells
    nxt = slice(first + 10, first + 15)
    waiting = scene.pot_positions(data)[nxt]
    assert np.allclose(waiting[:, :2], scene.pots.cell_xy[nxt] + scene.pots.offset[nxt]
                       - [0, pitch])  # fmt: skip


def test_the_ribs_move_to_the_rows_they_serve_at_each_index():
    cfg = SceneConfig(rows=20, live_rows=6)
    scene = build_scene(cfg, seed=1)
    data = scene.make_data()
    drive = ConveyorDrive(scene)
    assert drive.rib_rows.tolist() == list(range(7))
    for _ in range(300):  # the scene falls asleep
        mujoco.mj_step(scene.model, data)
    drive.start(data, data.time, 0.6)
    # after this index row 0 has gone round the drum: its ribs serve row 7
    assert drive.rib_rows.tolist() == [7, 1, 2, 3, 4, 5, 6]
    rib0 = scene.model.geom("rib_0_0").id
    assert scene.model.geom_conaffinity[rib0] == row_bit(7)
    while drive.armed(data):
        drive.apply(data, data.time)
        mujoco.mj_step(scene.model, data)
    y_rows = cfg.pickup_row_y_m + 7 * cfg.row_pitch_m - cfg.row_pitch_m / 2  # its rear rib
    assert data.geom_xpos[rib0, 1] == pytest.approx(y_rows + drive.position(data), abs=1e-4)


def test_rows_that_entered_are_pushed_along_by_the_ribs_that_moved_to_them():
    """Rows 6 and 7 enter the slots of rows 0 and 1 (row 7's ribs are row 0's, moved): two
    indexes carry every pot on the belt two row pitches, upright."""
    cfg = SceneConfig(rows=12, live_rows=6)
    scene = build_scene(cfg, seed=4)
    data, drive = scene.make_data(), ConveyorDrive(scene)
    for pot in range(10):
        scene.window.release(data, pot)
    assert (scene.window.state[30:40] == LIVE).all()
    m = scene.model
    rib0 = m.geom("rib_0_0").id
    mujoco.mj_forward(m, data)
    start = scene.pot_positions(data)
    for _ in range(2):
        drive.start(data, data.time, 0.6)
        assert m.body_conaffinity[m.geom_bodyid[rib0]] == row_bit(7)
        while drive.armed(data):
            drive.apply(data, data.time)
            mujoco.mj_step(m, data)
    moved = scene.pot_positions(data) - start
    on_belt = np.flatnonzero(scene.window.state == LIVE)
    assert on_belt.tolist() == list(range(10, 40))
    assert np.allclose(moved[on_belt, 1], -2 * cfg.row_pitch_m, atol=0.004)
    assert np.allclose(moved[on_belt, 2], 0.0, atol=1e-4)
    assert (np.abs(moved[on_belt, 0]) < 0.004).all()


def test_a_windowed_trial_judges_the_same_seedlings_and_rows_enter_settled():
    """31 seedlings on a 12-row belt with 6 live rows (pots on their cylinders and the PD
    index, whose jostle settles within 6 rows; the paper scenario's feet need 12): the pots
    of row 6 entered after the first index and had 5 pushes before their pickup; every
    seedling is judged on its own pot, as with a body per pot."""
    twins: list[Twin] = []

    def twin(config):
        twins.append(Twin(config))
        return twins[-1]

    result = run_trial(
        paper_config(31, **{"conveyor.rows": 12, "conveyor.live_rows": 6, **CYLINDERS}),
        twin_factory=twin,
    )
    window = twins[0].scene.window
    assert [r.pot for r in result.per_seedling] == list(range(31))
    assert sum(r.outcome == Outcome.SUCCESS for r in result.per_seedling) >= 29
    assert (window.entered_at[30:35] == 1).all()  # 5 pushes (indexes 2-6) before its pickup
    assert len(_pot_bodies(twins[0].model)) == 30
    parked = window.gone_pose[window.state == GONE]
    assert len(parked) >= 25 and (parked[:, 2] < 0.0).all()  # on the floor beside the machine


@pytest.mark.parametrize(
    "overrides, match",
    [
        ({"conveyor.rows": 20, "conveyor.live_rows": MIN_LIVE_ROWS - 1, **CYLINDERS},
         rf"conveyor.live_rows = {MIN_LIVE_ROWS - 1} is below the minimum of {MIN_LIVE_ROWS}"),
        ({"conveyor.rows": 20, "conveyor.live_rows": MIN_LIVE_ROWS_ON_FEET - 1, "pots.feet": 8},
         rf"live_rows = {MIN_LIVE_ROWS_ON_FEET - 1} is below the minimum of "
         rf"{MIN_LIVE_ROWS_ON_FEET} for conveyor.rows = 20 with pots on 8 feet"),
        ({"conveyor.rows": 20, "conveyor.live_rows": 6, "pots.bond_share": 0.1, **CYLINDERS},
         r"live_rows >= conveyor.rows"),
        ({"conveyor.rows": 20, "conveyor.live_rows": 6, "pots.canopy_contact": True, **CYLINDERS},
         r"live_rows >= conveyor.rows"),
    ],
)  # fmt: skip
def test_a_window_it_cannot_hold_is_refused(overrides, match):
    with pytest.raises(ScenarioError, match=match):
        paper_scenario(**overrides)
    with pytest.raises(ValueError, match="SceneConfig.live_rows"):
        SceneConfig(
            rows=20,
            live_rows=overrides["conveyor.live_rows"],
            pot_bond_share=overrides.get("pots.bond_share", 0.0),
            canopy_contact=overrides.get("pots.canopy_contact", False),
            pot_feet=overrides.get("pots.feet", 0),
        )
    # a window as wide as the belt is no window: anything goes
    assert paper_scenario(**{**overrides, "conveyor.live_rows": 20})


def test_leaf_hits_are_tested_on_the_pots_that_are_bodies():
    """A pot of an entered row raised into the gripper: its leaves are hit, found by its
    flat index, and a pot that left the physics is not tested."""
    scene = build_scene(SceneConfig(rows=12, live_rows=6), seed=2)
    data = scene.make_data()
    for pot in range(5):
        scene.window.release(data, pot)
    mujoco.mj_forward(scene.model, data)
    assert scene.leaf_hit_pots(data).size == 0
    adr = scene.pot_qpos_adr[32]  # row 6, in a slot of row 0
    grip = data.site_xpos[scene.grip_site]
    data.qpos[adr : adr + 3] = [grip[0], grip[1], grip[2] + 0.015]
    mujoco.mj_forward(scene.model, data)
    assert scene.leaf_hit_pots(data).tolist() == [32]


def test_failed_pots_leave_the_physics_at_rest_or_a_row_later_moving():
    """Sleep off: a pot the judge did not park leaves when its row is two indexes past the
    pickup and it is at rest; one still moving leaves an index later, counted."""
    scene = build_scene(SceneConfig(rows=12, live_rows=6, sleep=False), seed=1)
    data, window = scene.make_data(), scene.window
    for pot in range(4):  # pot 4 failed: it lies still where it is
        window.release(data, pot)
    window.on_index(data)
    assert window.state[4] == LIVE and window.state[30] != LIVE  # row 0 is one index past
    window.on_index(data)
    assert window.state[4] == GONE and (window.entered_at[30:35] == 2).all()
    for pot in range(5, 9):  # pot 9 failed and keeps moving
        window.release(data, pot)
    data.qvel[scene.pot_dof_adr[9]] = 0.5
    window.on_index(data)
    assert window.state[9] == LIVE and window.state[35] != LIVE
    window.on_index(data)
    assert window.state[9] == GONE and window.frozen_moving == 1
    assert (window.entered_at[35:40] == 4).all()


def test_the_render_model_draws_every_pot_where_the_window_puts_it():
    scene = build_scene(SceneConfig(rows=12, live_rows=6), seed=2)
    data = scene.make_data()
    data.qpos[scene.conveyor_qpos_adr] = -SceneConfig().row_pitch_m
    for pot in range(5):
        scene.window.release(data, pot)
    mujoco.mj_forward(scene.model, data)
    drawn = scene.render_data(data)
    model = scene.render_model
    assert len(_pot_bodies(model)) == 60  # a body per pot, with its decor
    where = np.array([drawn.xpos[model.body(f"pot_{p // 5}_{p % 5}").id] for p in range(60)])
    assert np.allclose(where, scene.pot_positions(data), atol=1e-12)
    assert np.allclose(where[32], data.xpos[scene.pot_bodies[6, 2]], atol=1e-12)
    grip = scene.model.site("grip_center").id
    assert np.allclose(drawn.site_xpos[grip], data.site_xpos[grip])
