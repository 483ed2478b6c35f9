"""The index pushes an entering row skipped, run in a model of that row alone
(transplanter.scene.row_pushes)."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from transplanter.scene import build_scene
from transplanter.scene.config import SceneConfig
from transplanter.scene.row_pushes import PUSH_CAP, RowPushes, modelled_indexes


@pytest.fixture(scope="module")
def belt():
    """A 12-row belt with a window of 6, seed 3, and its side model."""
    scene = build_scene(SceneConfig(rows=12, live_rows=6), seed=3)
    return scene, RowPushes(scene)


def test_the_pushes_modelled_are_the_skipped_ones_of_the_last_cap():
    assert PUSH_CAP == 17
    assert list(modelled_indexes(9, 3)) == [1, 2, 3]  # 6 to come: 9 in all
    assert list(modelled_indexes(6, 0)) == []  # entered before the first index
    # row 40 enters after 33 indexes: its last 17 before the pickup are indexes 24-40,
    # of which the window gives 34-40 and the side model 24-33
    assert list(modelled_indexes(40, 33)) == list(range(24, 34))
    assert list(modelled_indexes(40, 20)) == []  # nothing of the last 17 skipped yet


def test_the_ballast_is_the_rest_of_the_belt_at_that_index(belt):
    scene, side = belt
    pots, cfg = scene.pots, scene.config
    mass, friction = side.load(8, 2)  # index 2 drags rows 2-11; row 8 is the side model's
    others = np.r_[10:40, 45:60]
    each = pots.mass[others] + cfg.shoot_mass_kg
    assert mass == pytest.approx(each.sum(), rel=1e-12)
    assert friction == pytest.approx((each * pots.friction[others]).sum() / each.sum())
    assert 2.0 < mass < 2.4 and 0.5 < friction < 0.7  # 45 pots of about 50 g


def test_the_side_model_is_one_row_with_the_full_scenes_options(belt):
    scene, side = belt
    m = side.model(8)
    pots = [m.body(b).name for b in range(m.nbody) if m.body(b).name.startswith("pot_")]
    assert pots == [f"pot_8_{c}" for c in range(5)]
    assert m.nbody == 1 + 1 + 5 + 1  # world, carriage, pots, ballast
    for name in ("timestep", "impratio", "tolerance", "iterations", "cone", "enableflags"):
        assert np.array_equal(getattr(m.opt, name), getattr(scene.model.opt, name)), name
    table = m.geom("belt_table")
    assert np.array_equal(table.friction, scene.model.geom("belt_table").friction)


def test_pushed_pots_lie_against_their_rib_away_from_their_drawn_offsets(belt):
    """Three indexes move row 8's pots from their drawn offsets (sd about 1 mm both ways):
    along the belt onto the rib that pushed them, across it by a random walk; the same
    pushes give the same poses, bit for bit."""
    scene, side = belt
    poses = side.push(8, [1, 2, 3], 0.6)
    drawn = scene.pots.offset[40:45]
    assert poses.shape == (4, 5, 7)
    assert np.allclose(poses[0, :, :2], drawn, atol=2e-4)  # at rest as built
    after = poses[-1]
    # along: the rib leaves every pot 0.5-1.5 mm behind its cell centre (the carriage lags
    # its profile by the belt it drags), where the drawn offsets spread over +-2 mm
    assert np.all((after[:, 1] > 0.0003) & (after[:, 1] < 0.0015)), after[:, 1]
    assert np.ptp(drawn[:, 1]) > 0.002
    # across: every pot has moved, by up to a few millimetres
    moved = np.abs(after[:, 0] - drawn[:, 0])
    assert np.all(moved > 1e-5) and moved.max() > 5e-4 and moved.max() < 0.005
    assert np.allclose(after[:, 2], scene.pots.height[40:45] / 2, atol=2e-3)  # upright
    # upright: the pot's axis within 5 deg of vertical (it may turn about its axis)
    tilt = np.degrees(np.arccos(np.clip(1.0 - 2.0 * (after[:, 4] ** 2 + after[:, 5] ** 2), -1, 1)))
    assert np.all(tilt < 5.0), tilt
    assert np.array_equal(side.push(8, [1, 2, 3], 0.6), poses)


def test_a_row_cannot_be_pushed_past_the_pickup(belt):
    _, side = belt
    with pytest.raises(ValueError, match="row 2 can be pushed by at most 2"):
        side.push(2, [1, 2, 3], 0.6)


def test_an_entering_row_arrives_with_its_pushes_deterministically():
    """Row 6 enters a 12-row belt after two indexes: its pots stand where the side model's
    indexes 1 and 2 leave them, not at their drawn offsets, and a fresh scene of the same
    seed puts them at the same place, bit for bit."""
    placed = []
    for _ in range(2):
        scene = build_scene(SceneConfig(rows=12, live_rows=6), seed=3)
        data = scene.make_data()
        data.qpos[scene.conveyor_qpos_adr] = -2 * scene.config.row_pitch_m
        scene.window.index_s = 0.6
        for pot in range(5):
            scene.window.release(data, pot)
        mujoco.mj_forward(scene.model, data)
        placed.append(scene.pot_positions(data)[30:35].copy())
    assert np.array_equal(placed[0], placed[1])
    assert (scene.window.side_pushes[30:35] == 2).all()
    carried = scene.pots.cell_xy[30:35] - [0, 2 * scene.config.row_pitch_m]
    offset = placed[0][:, :2] - carried
    assert np.abs(offset - scene.pots.offset[30:35]).max() > 5e-4
    assert np.allclose(offset, RowPushes(scene).push(6, [1, 2], 0.6)[-1, :, :2], atol=1e-12)
