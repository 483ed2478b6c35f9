"""Scene builder: grasp by friction, drop tube, sleeping, conveyor indexing, pot batches."""

import copy
import math
from dataclasses import replace

import mujoco
import numpy as np
import pytest

from transplanter.machine.kinematics import fivebar as kinematics
from transplanter.scene import (
    ConveyorDrive,
    PotBatch,
    SceneConfig,
    build_scene,
)


def ik(cfg, x, y):
    """Paper working mode (elbows out) IK for a scene config."""
    return kinematics.ik(cfg.geometry(), x, y)


class Runner:
    """Straight-line Cartesian moves with min-jerk timing, test-local."""

    def __init__(self, scene):
        self.scene, self.model = scene, scene.model
        self.data = scene.make_data()
        self.conveyor = ConveyorDrive(scene)
        self.p = self.data.site_xpos[scene.grip_site].copy()
        self.target = scene.joint_positions(self.data)  # the steppers' fields (power-on)

    def step(self, n=1):
        for _ in range(n):
            self.scene.hold_motors(self.data, self.target)
            self.conveyor.apply(self.data, self.data.time)
            mujoco.mj_step(self.model, self.data)

    def step_until(self, t):
        """Step until data.time >= t (bounded: the steps t needs, plus one)."""
        dt = self.model.opt.timestep
        for _ in range(max(math.ceil((t - self.data.time) / dt), 0) + 1):
            if self.data.time >= t:
                return
            self.step()

    def move(self, target, speed):
        target = np.asarray(target, float)
        length = np.linalg.norm(target - self.p)
        n = max(int(length / speed * 1.875 / self.model.opt.timestep), 20)
        cfg = self.scene.config
        for i in range(1, n + 1):
            s = i / n
            s = s**3 * (10 - 15 * s + 6 * s * s)
            x, y, z = self.p + (target - self.p) * s
            t1, t2 = ik(cfg, x, y)
            self.target = [t1, t2, z]
            self.step()
        self.p = target


def grasp_and_carry(scene, cell_x=0.0, z_low=0.032, lift=0.04):
    """Grip the pot of the pickup row's cell at cell_x, lift it `lift`, carry it 150 mm."""
    run = Runner(scene)
    run.step(300)  # let the pots settle (and fall asleep)
    cfg, y0 = scene.config, scene.config.pickup_row_y_m
    t1, t2 = ik(cfg, cell_x, y0 - 0.03)
    psi1 = t1 + cfg.kinematics().passive_angles(t1, t2)[0]
    scene.set_wrist_angle(run.data, math.pi / 2 - psi1)
    scene.set_gripper_opening(run.data, 0.041)
    run.move([cell_x, y0 - 0.03, 0.10], 0.05)
    run.move([cell_x, y0 - 0.03, z_low], 0.05)
    run.move([cell_x, y0, z_low], 0.05)
    scene.set_gripper_opening(run.data, 0.0)
    run.step(300)
    grip_force = scene.grip_force(run.data)
    run.move([cell_x, y0, z_low + lift], 0.04)
    run.move([cell_x + 0.075, y0, z_low + lift], 0.3)
    run.move([cell_x - 0.075, y0, z_low + lift], 0.5)  # the 150 mm carry at 0.5 m/s
    run.step(200)
    return run, grip_force


def one_heavy_pot(friction):
    return SceneConfig(
        rows=1,
        cols=1,
        pot_mass_kg=0.08,
        pot_mass_sd_kg=0.0,
        pot_friction=friction,
        pot_friction_sd=0.0,
    )


@pytest.mark.slow
def test_friction_grasp_carries_an_80g_pot_and_frictionless_pot_is_lost():
    scene = build_scene(one_heavy_pot(0.6), seed=0)
    run, grip_force = grasp_and_carry(scene)
    assert grip_force == pytest.approx(2 * scene.config.grip_force_n, rel=0.05)
    pot = scene.pot_positions(run.data)[0]
    grip = run.data.site_xpos[scene.grip_site]
    assert np.linalg.norm(pot[:2] - grip[:2]) < 0.005
    assert pot[2] > 0.055  # lifted: resting centre is at 0.026 m
    assert scene.pots_touching_jaws(run.data).tolist() == [0]
    assert run.data.warning.number.sum() == 0

    slippery = build_scene(one_heavy_pot(0.0), seed=0)
    run, _ = grasp_and_carry(slippery)
    pot = slippery.pot_positions(run.data)[0]
    assert np.linalg.norm(pot[:2] - run.data.site_xpos[slippery.grip_site][:2]) > 0.05
    assert pot[2] < 0.03


@pytest.mark.parametrize("offset, inside", [(0.0, True), (0.06, False)])
def test_pot_released_above_funnel_lands_in_tube(offset, inside):
    scene = build_scene(SceneConfig(rows=1, cols=1), seed=0)
    data = scene.make_data()
    adr = scene.pot_qpos_adr[0]
    x, y = scene.config.drop_tube_xy_m
    data.qpos[adr : adr + 3] = [x + offset, y, 0.06]
    for _ in range(800):
        mujoco.mj_step(scene.model, data)
    assert scene.pot_in_tube(data)[0] == inside


@pytest.mark.slow
def test_sleeping_does_not_change_a_grasp():
    results = []
    for sleep in (True, False):
        scene = build_scene(SceneConfig(rows=3, cols=1, sleep=sleep), seed=4)
        run, _ = grasp_and_carry(scene)
        results.append(scene.pot_positions(run.data))
    assert np.abs(results[0] - results[1]).max() < 0.001


@pytest.mark.slow
def test_dense_jacobian_gives_the_same_grasp():
    results = []
    for jac in ("sparse", "dense"):
        scene = build_scene(SceneConfig(rows=1, cols=3, jacobian=jac), seed=2)
        # lifted 70 mm, the pot's bottom (38 mm below the grip centre) clears the 52 mm
        # neighbours: knocking them over would make the comparison chaotic
        run, _ = grasp_and_carry(scene, lift=0.07)
        assert scene.pots_touching_jaws(run.data).tolist() == [1]
        results.append(scene.pot_positions(run.data))
    assert np.abs(results[0] - results[1]).max() < 0.001


@pytest.mark.parametrize("pot_diameter", [0.035, 0.033, 0.030])
def test_conveyor_index_moves_pots_one_row_and_they_rest(pot_diameter):
    cfg = SceneConfig(rows=3, cols=3, pot_diameter_m=pot_diameter)
    assert cfg.index_overshoot_m == pytest.approx((0.045 - 0.002 - pot_diameter) / 2)
    scene = build_scene(cfg, seed=5)
    run = Runner(scene)
    # the pickup row has been emptied (its pots moved away onto the ground)
    for c in range(cfg.cols):
        adr = scene.pot_qpos_adr[c]
        run.data.qpos[adr : adr + 3] = [0.4 + 0.05 * c, 0.0, -0.13]
    run.step(300)
    assert run.data.ntree_awake == 1  # only the arm: pots and conveyor asleep
    back_rows = slice(cfg.cols, None)
    before = scene.pot_positions(run.data)[back_rows]
    run.conveyor.start(run.data, run.data.time, 1.0)
    assert run.conveyor.indexing(run.data, run.data.time)
    run.step_until(run.data.time + 1.0)
    assert not run.conveyor.indexing(run.data, run.data.time)
    run.step(300)
    after = scene.pot_positions(run.data)[back_rows]
    moved = before - after
    # the ribs re-centre each pot in its cell (whatever the pot size): displacement = pitch +
    # its placement offset; a fixed 4 mm overshoot left 30 mm pots 2.8 mm off centre
    offset_y = scene.pots.offset[back_rows, 1]
    assert np.abs(moved[:, 1] - cfg.row_pitch_m - offset_y).max() < 0.001
    # sideways the smaller pots have more play in their cells (5 mm each side for 33 mm)
    assert np.abs(moved[:, 0]).max() < 0.003
    cells = scene.pots.cell_xy[back_rows] - [0, cfg.row_pitch_m]
    assert np.abs(after[:, 1] - cells[:, 1]).max() < 0.001
    assert np.abs(after[:, 0] - cells[:, 0]).max() < cfg.pot_offset_max_m + 0.003
    assert np.abs(run.data.qvel[scene.pot_dof_adr[back_rows, None] + np.arange(3)]).max() < 1e-3
    assert run.data.ntree_awake == 1  # all asleep again
    assert scene.conveyor_position(run.data) == pytest.approx(-cfg.row_pitch_m, abs=1e-3)


def test_conveyor_overshoot_can_be_set():
    assert SceneConfig(conveyor_overshoot_m=0.002).index_overshoot_m == 0.002
    # by default it is the cell clearance, whatever the pot size
    for diameter in (0.030, 0.035):
        cfg = SceneConfig(pot_diameter_m=diameter)
        assert cfg.index_overshoot_m == cfg.cell_clearance_m
        assert diameter + 2 * cfg.index_overshoot_m + cfg.rib_thickness_m == pytest.approx(0.045)
    with pytest.raises(ValueError, match="conveyor_overshoot_m"):
        SceneConfig(conveyor_overshoot_m=-0.001)


def rollout_qpos(seed, steps=200):
    """qpos after `steps` physics steps of a fresh 2x2 scene with the arm moving."""
    scene = build_scene(SceneConfig(rows=2, cols=2), seed=seed)
    data = scene.make_data()
    conveyor = ConveyorDrive(scene)
    home = scene.joint_positions(data)
    for i in range(steps):
        scene.hold_motors(data, home + [-0.002 * i, 0.001 * i, -0.0002 * i])
        conveyor.apply(data, data.time)
        mujoco.mj_step(scene.model, data)
    pot_xyz = data.qpos[scene.pot_qpos_adr[:, None] + np.arange(3)].copy()
    return scene.pots, data.qpos.copy(), pot_xyz


def test_build_and_rollout_are_deterministic_and_seed_dependent():
    a, qpos_a, pots_a = rollout_qpos(7)
    b, qpos_b, _ = rollout_qpos(7)
    c, qpos_c, pots_c = rollout_qpos(8)
    assert a == b
    assert not np.array_equal(a.mass, c.mass)
    assert np.array_equal(qpos_a, qpos_b)  # bit-identical
    assert not np.array_equal(qpos_a, qpos_c)
    assert not np.array_equal(pots_a, pots_c)


def test_leaf_proxies_report_hits_without_force():
    scene = build_scene(SceneConfig(rows=1, cols=1), seed=0)
    data = scene.make_data()
    assert not scene.leaf_hits(data)
    # raise the pot between the jaws until its leaves reach the palm (the bridge, 68 mm over
    # the grip centre): they overlap the gripper
    adr = scene.pot_qpos_adr[0]
    grip = data.site_xpos[scene.grip_site]
    data.qpos[adr : adr + 3] = [grip[0], grip[1], grip[2] + 0.015]
    mujoco.mj_forward(scene.model, data)
    assert scene.leaf_hits(data)
    assert scene.leaf_hit_pots(data).tolist() == [0]


def test_physics_model_leaves_out_the_decor_and_the_render_model_mirrors_it():
    """The physics model has only collision geoms on the pots; the decorated model has the
    same bodies, joints and actuators, and its leaf proxies sit where Scene.leaves puts
    them for the physics state it mirrors."""
    scene = build_scene(SceneConfig(rows=2, cols=3), seed=4)
    m, decor = scene.model, scene.render_model
    for n in ("nbody", "njnt", "nq", "nv", "nu", "neq", "nkey"):
        assert getattr(m, n) == getattr(decor, n), n
    pot_geoms = [g for g in range(m.ngeom) if m.geom(g).name.startswith("pot_")]
    assert len(pot_geoms) == 6  # one collision cylinder per pot, nothing else on a pot
    # pot mesh, stem, and a mesh and a proxy per leaf
    assert m.ngeom == decor.ngeom - sum(2 + 2 * int(k) for k in scene.pots.n_leaves)
    np.testing.assert_array_equal(m.body_mass, decor.body_mass)
    data = scene.make_data()
    adr = scene.pot_qpos_adr[4]
    data.qpos[adr : adr + 7] = [0.01, 0.2, 0.05, 0.9, 0.1, -0.3, 0.2]  # a tilted pot
    data.qpos[adr + 3 : adr + 7] /= np.linalg.norm(data.qpos[adr + 3 : adr + 7])
    mujoco.mj_forward(m, data)
    mirror = scene.render_data(data)
    np.testing.assert_array_equal(mirror.xpos, data.xpos)
    rows = np.flatnonzero(scene.leaves.pot == 4)
    body = scene.pot_bodies.ravel()[4]
    rot = data.xmat[body].reshape(3, 3)
    for k, row in enumerate(rows):
        g = decor.geom(f"leaf_1_1_{k}").id
        expected = data.xpos[body] + rot @ scene.leaves.centre[row]
        np.testing.assert_allclose(mirror.geom_xpos[g], expected, atol=1e-12)
        np.testing.assert_allclose(
            mirror.geom_xmat[g].reshape(3, 3)[:, 2], rot @ scene.leaves.axis[row], atol=1e-12
        )


def _pose_with_leaf_in_the_left_jaw(scene) -> np.ndarray:
    """Pot 0's free-joint pose (upright) that puts its leaf proxy 0 at the left jaw's centre."""
    m, data = scene.model, scene.make_data()
    pot = scene.pot_bodies.ravel()[0]
    offset = data.geom_xpos[m.geom("leaf_0_0_0").id] - data.xpos[pot]  # pot frame = world's
    return np.r_[data.geom_xpos[m.geom("jaw_left").id] - offset, 1.0, 0.0, 0.0, 0.0]


def test_canopy_contact_lets_the_leaves_touch_the_jaws_and_nothing_else():
    """With canopy_contact each leaf proxy is in the physics model, collides with the two
    jaws only (soft, its own friction), and a jaw pressing a leaf pushes the pot; without it
    the physics model has no leaves at all."""
    off = build_scene(SceneConfig(rows=1, cols=1), seed=2)
    assert not any(off.model.geom(g).name.startswith("leaf_") for g in range(off.model.ngeom))
    cfg = SceneConfig(rows=1, cols=1, canopy_contact=True, canopy_timeconst_s=0.1)
    scene = build_scene(cfg, seed=2)
    m = scene.model
    leaves = [g for g in range(m.ngeom) if m.geom(g).name.startswith("leaf_")]
    assert len(leaves) == scene.pots.n_leaves[0]
    for g in leaves:
        partners = {
            m.geom(o).name
            for o in range(m.ngeom)
            if (m.geom_contype[g] & m.geom_conaffinity[o])
            or (m.geom_contype[o] & m.geom_conaffinity[g])
        }
        assert partners == {"jaw_left", "jaw_right"}, partners
        assert m.geom_solref[g].tolist() == [0.1, 1.0]
        assert m.geom_friction[g, 0] == cfg.canopy_friction
    pose = _pose_with_leaf_in_the_left_jaw(scene)
    sideways = []
    for built in (off, scene):
        data = built.make_data()
        adr = built.pot_qpos_adr[0]
        data.qpos[adr : adr + 7] = pose  # the same pose in both scenes
        mujoco.mj_forward(built.model, data)
        names = {
            tuple(sorted(built.model.geom(g).name for g in c.geom))
            for c in data.contact[: data.ncon]
        }
        assert (("jaw_left", "leaf_0_0_0") in names) == (built is scene), names
        pot = built.pot_bodies.ravel()[0]
        start = data.xpos[pot].copy()
        held = built.joint_positions(data)  # the motors hold the machine where it stands
        for _ in range(200):
            built.hold_motors(data, held)
            mujoco.mj_step(built.model, data)
        sideways.append(float(np.linalg.norm(data.xpos[pot, :2] - start[:2])))
    assert sideways[0] < 0.0005 < 0.001 < sideways[1], sideways  # only the leaf pushes it


def test_soaked_pots_are_drawn_last_and_get_a_wall_that_gives():
    """pots.soft_share: a share of the pots soaked, drawn after everything else (a seed's
    other draws do not change), their contacts giving over pot_soft_wall_m (solimp width)."""
    firm = PotBatch.draw(SceneConfig(rows=4, cols=5), seed=3)
    cfg = SceneConfig(rows=4, cols=5, pot_soft_share=0.5, pot_soft_wall_m=0.03)
    soaked = PotBatch.draw(cfg, seed=3)
    for name in ("diameter", "mass", "friction", "offset", "bond_force", "leaf_yaw0"):
        np.testing.assert_array_equal(getattr(firm, name), getattr(soaked, name))
    assert not firm.soft.any() and 5 <= soaked.soft.sum() <= 15
    scene = build_scene(cfg, seed=3)
    m = scene.model
    for i, geom in enumerate(scene.pot_geoms):
        width = m.geom_solimp[geom, 2]
        assert width == (0.03 if soaked.soft[i] else cfg.contact_solimp[2])
    with pytest.raises(ValueError, match="pot_soft_share"):
        SceneConfig(pot_soft_share=1.5)


def test_shoot_sway_frequencies_are_drawn_last_from_a_gamma():
    """pots.stem_sway_sd_hz: each seedling's sway frequency from a gamma distribution (never
    <= 0), drawn after every other draw, so a seed keeps its pots when the spread changes."""
    same = PotBatch.draw(SceneConfig(rows=8, cols=5), seed=4)
    assert (same.sway_hz == 4.0).all()
    spread = PotBatch.draw(SceneConfig(rows=8, cols=5, stem_sway_sd_hz=1.0), seed=4)
    for name in ("diameter", "mass", "friction", "offset", "stem_length", "soft"):
        np.testing.assert_array_equal(getattr(same, name), getattr(spread, name))
    big = PotBatch.draw(SceneConfig(rows=100, cols=20, stem_sway_sd_hz=1.0), seed=4)
    assert big.sway_hz.mean() == pytest.approx(4.0, abs=0.05)
    assert big.sway_hz.std() == pytest.approx(1.0, abs=0.05)
    assert big.sway_hz.min() > 0
    with pytest.raises(ValueError, match="stem_sway_hz must be > 0 Hz"):
        SceneConfig(stem_sway_hz=0.0)


def test_crooked_pots_stand_on_their_foot_with_the_wall_and_seedling_leaning():
    """pots.crooked_share: a share of the pots (drawn last) get a flat foot and a wall that
    leans by up to pot_crooked_max_rad towards a random side; the pot stands upright on its foot
    while its wall and its seedling's leaves lean (in the physics and in the decor alike)."""
    straight = PotBatch.draw(SceneConfig(rows=4, cols=5), seed=5)
    cfg = SceneConfig(rows=4, cols=5, pot_crooked_share=0.5, pot_crooked_max_rad=0.15)
    scene = build_scene(cfg, seed=5)
    pots = scene.pots
    for name in ("diameter", "mass", "friction", "offset", "stem_length", "sway_hz"):
        np.testing.assert_array_equal(getattr(straight, name), getattr(pots, name))
    crooked = np.flatnonzero(pots.crook > 0)
    assert 5 <= crooked.size <= 15 and pots.crook.max() < 0.15
    assert not straight.crook.any()
    m, data = scene.model, scene.make_data()
    for _ in range(1500):
        mujoco.mj_step(m, data)
    bodies = scene.pot_bodies.ravel()
    assert np.degrees(np.arccos(data.xmat[bodies, 8])).max() < 0.5  # all stand on their feet
    for i in range(len(pots)):
        wall = scene.pot_geoms[i]
        lean = np.arccos(data.geom_xmat[wall, 8])
        assert lean == pytest.approx(pots.crook[i], abs=0.01)
        if pots.crook[i] > 0:  # the wall's top leans towards its azimuth
            top = data.geom_xpos[wall] - data.xpos[bodies[i]]
            direction = np.arctan2(top[1], top[0])
            assert np.cos(direction - pots.crook_azimuth[i]) > 0.99
            foot = m.geom(f"pot_foot_{i // cfg.cols}_{i % cfg.cols}").id
            assert m.geom_bodyid[foot] == bodies[i] and m.geom_friction[foot, 0] == pots.friction[i]
    # the leaf proxies the leaf test uses lean with the wall, as the decor draws them
    mirror = scene.render_data(data)
    decor = scene.render_model
    for row, (pot, centre) in enumerate(zip(scene.leaves.pot, scene.leaves.centre, strict=True)):
        r, c = divmod(int(pot), cfg.cols)
        k = int((scene.leaves.pot[:row] == pot).sum())
        g = decor.geom(f"leaf_{r}_{c}_{k}").id
        rot = data.xmat[bodies[pot]].reshape(3, 3)
        np.testing.assert_allclose(
            mirror.geom_xpos[g], data.xpos[bodies[pot]] + rot @ centre, atol=1e-12
        )
    with pytest.raises(ValueError, match="pot_crooked_max_rad"):
        SceneConfig(pot_crooked_max_rad=1.0)


def test_an_uneven_fill_lowers_the_pots_mass_and_its_seedling():
    """pots.fill_gap: each pot's soil lies a drawn gap below its rim (drawn last): the pot's
    centre of mass sits half the gap lower, its seedling's leaves the whole gap lower."""
    full = build_scene(SceneConfig(rows=2, cols=5), seed=6)
    cfg = SceneConfig(rows=2, cols=5, pot_fill_gap_m=0.008, pot_fill_gap_sd_m=0.004)
    uneven = build_scene(cfg, seed=6)
    gap = uneven.pots.fill_gap
    assert not full.pots.fill_gap.any() and gap.min() >= 0 and 0.004 < gap.mean() < 0.012
    for name in ("diameter", "height", "mass", "friction", "offset", "stem_length", "crook"):
        np.testing.assert_array_equal(getattr(full.pots, name), getattr(uneven.pots, name))
    bodies = uneven.pot_bodies.ravel()
    np.testing.assert_allclose(uneven.model.body_ipos[bodies, 2], -gap / 2, rtol=1e-12)
    np.testing.assert_array_equal(full.model.body_ipos[full.pot_bodies.ravel()], 0.0)
    drop = full.leaves.centre[:, 2] - uneven.leaves.centre[:, 2]
    np.testing.assert_allclose(drop, gap[uneven.leaves.pot], rtol=1e-9)
    with pytest.raises(ValueError, match="pot_fill_gap_m"):
        SceneConfig(pot_fill_gap_m=0.05)


def test_canopy_softness_below_two_timesteps_is_refused():
    with pytest.raises(ValueError, match="canopy_timeconst_s must be at least twice the timestep"):
        SceneConfig(canopy_contact=True, canopy_timeconst_s=0.0015)
    SceneConfig(canopy_contact=False, canopy_timeconst_s=0.0015)  # unused: not checked


def test_bad_config_is_rejected():
    with pytest.raises(ValueError, match="pot_diameter_m"):
        SceneConfig(pot_diameter_m=0.044)
    with pytest.raises(ValueError, match="rows"):
        SceneConfig(rows=0)


def test_joint_ranges_come_from_the_config():
    cfg = SceneConfig(rows=1, cols=1, z_range_m=(0.002, 0.170), theta2_range_rad=(-1.2, 1.9))
    model = build_scene(cfg, seed=0).model
    assert model.joint("z").range.tolist() == [0.002, 0.170]
    assert model.joint("theta2").range.tolist() == [-1.2, 1.9]
    assert model.joint("theta1").range.tolist() == pytest.approx(
        [math.radians(75.0), math.radians(240.0)]
    )


@pytest.mark.parametrize(
    "fields, names",
    [
        ({"switch1_theta1_rad": math.radians(245.0)}, "switch1_theta1_rad.*theta1_range_rad"),
        ({"switch2_theta2_rad": math.radians(-65.0)}, "switch2_theta2_rad.*theta2_range_rad"),
        ({"switch3_z_m": 0.170}, "switch3_z_m.*z_range_m"),
        ({"z_range_m": (0.010, 0.165)}, "switch4_z_m.*z_range_m"),
        ({"power_on_z_m": -0.001}, "power_on_z_m.*z_range_m"),
        ({"power_on_theta1_rad": math.radians(241.0)}, "power_on_theta1_rad.*theta1_range_rad"),
        ({"theta2_range_rad": (0.5, -0.5)}, "theta2_range_rad"),
    ],
)
def test_switches_and_home_outside_the_joint_ranges_are_rejected(fields, names):
    with pytest.raises(ValueError, match=names):
        SceneConfig(**fields)


@pytest.mark.parametrize("steps", [0, 1.5])
def test_steps_per_rev_must_be_a_positive_integer(steps):
    with pytest.raises(ValueError, match="steps_per_rev"):
        SceneConfig(steps_per_rev=steps)


@pytest.mark.parametrize(
    "theta1, theta2, phi1, phi2",
    [  # values of the former circle-intersection implementation
        (3.4033920413889427, -0.2617993877991494, -2.8109069303869374, 2.8109069303869374),
        (2.0, 1.0, -1.0343383966671946, 1.1001743575806646),
        (2.6179938779914944, 0.5235987755982988, -1.925435895031676, 1.9254358950316757),
        (1.9198621771937625, -0.5235987755982988, -1.8104598062679087, 2.3273008656294945),
        (3.6651914291880923, 1.3962634015954636, -2.2236494718946593, 1.6443842775585358),
    ],
)
def test_passive_angles_of_the_model_assembly(theta1, theta2, phi1, phi2):
    assert SceneConfig().kinematics().passive_angles(theta1, theta2) == pytest.approx(
        (phi1, phi2), abs=1e-12
    )


def test_passive_angles_close_the_chain_and_reject_an_open_one():
    cfg = SceneConfig(l0_m=0.04, l1_m=0.1, l2_m=0.18)
    theta1, theta2 = 2.2, 0.8
    phi1, phi2 = cfg.kinematics().passive_angles(theta1, theta2)
    assert (phi1, phi2) == pytest.approx((-1.2913393613934392, 1.3455715703266806), abs=1e-12)
    b, d = kinematics.elbow_points(cfg.geometry(), theta1, theta2)
    c1 = b + cfg.l2_m * np.array([math.cos(theta1 + phi1), math.sin(theta1 + phi1)])
    c2 = d + cfg.l2_m * np.array([math.cos(theta2 + phi2), math.sin(theta2 + phi2)])
    assert np.linalg.norm(c1 - c2) < 1e-12
    with pytest.raises(ValueError, match="cannot close"):
        SceneConfig(l2_m=0.1).kinematics().passive_angles(math.pi, 0.0)


def test_conveyor_index_is_done_within_the_index_time():
    """The SGF acknowledges M710 after the index time: by then the carriage is at rest, its
    force released, and the next index may start."""
    cfg = SceneConfig(rows=3, cols=3)
    scene = build_scene(cfg, seed=5)
    run = Runner(scene)
    conveyor = run.conveyor
    assert conveyor.index_phases(0.6) == pytest.approx((0.5, 0.1))
    assert conveyor.index_phases(0.2) == pytest.approx((0.15, 0.05))
    run.step(300)
    data, dof = run.data, scene.conveyor_dof_adr
    for index in (1, 2):  # the second index starts the moment the first is acknowledged
        for c in range(cfg.cols):  # the pickup row has been emptied
            adr = scene.pot_qpos_adr[(index - 1) * cfg.cols + c]
            data.qpos[adr : adr + 3] = [0.4 + 0.05 * c, 0.1 * index, -0.13]
        t0 = data.time
        conveyor.start(data, t0, 0.6)
        run.step_until(t0 + 0.59)
        assert conveyor.indexing(data, data.time)
        with pytest.raises(RuntimeError, match="already indexing"):
            conveyor.start(data, data.time, 0.6)
        run.step_until(t0 + 0.6 - 1e-9)
        assert not conveyor.indexing(data, data.time)
        assert abs(data.qvel[dof]) < 1e-3
        back_rows = slice(index * cfg.cols, None)
        pot_vel = data.qvel[scene.pot_dof_adr[back_rows, None] + np.arange(3)]
        assert np.abs(pot_vel).max() < 5e-3  # a few mm/s of rocking, asleep soon after
        assert scene.conveyor_position(data) == pytest.approx(-index * cfg.row_pitch_m, abs=2e-4)
        conveyor.apply(data, data.time)
        assert data.qfrc_applied[dof] == 0.0
    run.step(300)
    assert data.ntree_awake == 1  # carriage and pots asleep again


def test_conveyor_index_time_must_be_positive():
    scene = build_scene(SceneConfig(rows=1, cols=1), seed=0)
    with pytest.raises(ValueError, match="index time"):
        ConveyorDrive(scene).start(scene.make_data(), 0.0, 0.0)


def test_pot_batch_of_a_seed_is_the_one_drawn_before_the_refactor():
    """Seed 0, default config: diameters and heights as the former scene.py drew them; mass,
    friction and offset from the same normal draws through a truncated normal and a gamma
    distribution (no clipping) since the no-silent-clamps change."""
    pots = PotBatch.draw(SceneConfig(), seed=0)
    assert len(pots) == 40
    pick = [0, 1, -1]
    assert pots.diameter[pick].tolist() == [
        0.03503771906632802, 0.034960368541012615, 0.03544802934356623,
    ]  # fmt: skip
    assert pots.height[pick].tolist() == [
        0.0509927475743167, 0.05321113901979125, 0.0536019140669162,
    ]  # fmt: skip
    assert pots.mass[pick].tolist() == [
        0.04893565763042725, 0.04473561579283509, 0.05444971694371993,
    ]  # fmt: skip
    assert pots.friction[pick].tolist() == [
        0.6388039437582874, 0.6417537240274827, 0.48671194962999564,
    ]  # fmt: skip
    assert pots.offset.ravel()[pick].tolist() == [
        0.0005115394055106994, -0.00029675658326671326, -0.0011374411329239408,
    ]  # fmt: skip
    assert pots.stem_length[[0, -1]].tolist() == [0.04102848905241116, 0.04363786241097085]
    assert pots.n_leaves[:8].tolist() == [2, 3, 3, 2, 2, 3, 3, 3]
    assert pots.leaf_yaw0[[0, -1]].tolist() == [5.189642282699918, 3.841154238748444]
    cells = pots.cell_xy[[0, 4, 5]].ravel().tolist()
    assert cells == pytest.approx([-0.09, 0.215, 0.09, 0.215, -0.09, 0.26])


def test_pot_batch_is_what_the_scene_is_built_from_and_is_read_only():
    cfg = SceneConfig(rows=2, cols=3)
    scene = build_scene(cfg, seed=11)
    pots = scene.pots
    assert pots == PotBatch.draw(cfg, seed=11)
    assert pots != PotBatch.draw(cfg, seed=12)
    m = scene.model
    for i in range(len(pots)):
        body = m.body(f"pot_{i // cfg.cols}_{i % cfg.cols}")
        geom = m.geom(f"pot_{i // cfg.cols}_{i % cfg.cols}")
        assert body.mass[0] == pots.mass[i] + cfg.shoot_mass_kg
        assert geom.size[:2].tolist() == [pots.diameter[i] / 2, pots.height[i] / 2]
        assert geom.friction[0] == pots.friction[i]
        decor = scene.render_model
        prefix = f"leaf_{i // 3}_{i % 3}_"
        leaves = [g for g in range(decor.ngeom) if decor.geom(g).name.startswith(prefix)]
        assert len(leaves) == pots.n_leaves[i] == (scene.leaves.pot == i).sum()
    with pytest.raises(ValueError, match="read-only"):
        pots.mass[0] = 1.0
    with pytest.raises(AttributeError):
        pots.mass = pots.height


def rib_rows_colliding(scene):
    m = scene.model
    return [bool(m.geom(f"rib_{r}_0").conaffinity[0] != 0) for r in range(scene.config.rows)]


def test_rows_past_the_edge_follow_the_carriage_position_of_each_index():
    """Ribs of rows carried past the front edge stop colliding; which rows are off depends on
    the state being indexed, so a rewound (copied) MjData gets its rows back."""
    scene = build_scene(SceneConfig(rows=3, cols=1), seed=0)
    drive, pitch = ConveyorDrive(scene), scene.config.row_pitch_m
    data = scene.make_data()
    snapshot = copy.copy(data)  # MjData copies with its userdata: the drive's whole state
    assert rib_rows_colliding(scene) == [True, True, True]
    data.qpos[scene.conveyor_qpos_adr] = -pitch  # as after one index
    drive.start(data, 0.0, 0.6)
    assert rib_rows_colliding(scene) == [False, False, True]
    assert drive.armed(data) and not drive.armed(snapshot)
    drive.start(snapshot, 0.0, 0.6)  # back to the state before the first index
    assert rib_rows_colliding(scene) == [False, True, True]
    resumed = copy.copy(snapshot)
    assert drive.indexing(resumed, 0.3) and drive.reference(resumed, 0.3) == drive.reference(
        snapshot, 0.3
    )


@pytest.mark.slow
def test_jaw_pot_contacts_take_the_pots_friction():
    """The pot's friction (scenario pots.friction), not a jaw setting, acts at the jaws."""
    for friction in (0.45, 0.9):
        scene = build_scene(one_heavy_pot(friction), seed=0)
        run, _ = grasp_and_carry(scene)
        d, m = run.data, scene.model
        jaws = {m.geom("jaw_left").id, m.geom("jaw_right").id}
        pot = m.geom("pot_0_0").id
        mus = [c.friction[0] for c in d.contact[: d.ncon] if {c.geom1, c.geom2} & jaws
               and pot in (c.geom1, c.geom2)]  # fmt: skip
        assert mus and all(mu == pytest.approx(friction) for mu in mus)


@pytest.mark.slow
def test_a_conveyor_of_100_rows_builds_and_runs():
    """Every size the schema accepts builds: per-row collision bits are reused 23 rows apart
    (bit 31 would overflow), and a pot only touches the ribs of its own row."""
    scene = build_scene(SceneConfig(rows=100, cols=1), seed=0)
    data = scene.make_data()
    for _ in range(200):
        mujoco.mj_step(scene.model, data)
    assert data.warning.number.sum() == 0
    pots = scene.pot_positions(data)
    assert pots.shape == (100, 3)
    assert np.abs(pots[:, 2] - scene.config.pot_height_m / 2).max() < 0.003  # all standing
    m = scene.model
    assert (m.geom_contype >= 0).all() and (m.geom_conaffinity >= 0).all()


def test_the_conveyor_drive_holds_the_carriage_between_indexes():
    """The carriage is held by its drive (a NEMA17's detent stiffness through a GT2 20T
    pulley, about 493 kN/m): a 50 N push between indexes moves it 0.1 mm, not the 20 mm that
    its slide friction alone allowed, and it comes back when the push ends; after an index the
    drive holds the new position, and the carriage still falls asleep."""
    cfg = SceneConfig(rows=3, cols=3)
    k = cfg.conveyor_hold_stiffness_n_m
    assert k == pytest.approx(0.40 * (math.pi / 2) / (2 * math.pi / 200) / 0.00637**2)
    assert 4.9e5 < k < 5.0e5
    scene = build_scene(cfg, seed=5)
    run = Runner(scene)
    data, dof, conveyor = run.data, scene.conveyor_dof_adr, run.conveyor
    run.step(300)
    assert data.ntree_awake == 1
    push = 50.0
    for sign in (+1, -1):
        data.qfrc_applied[dof] = sign * push
        run.step(200)
        friction = cfg.conveyor_frictionloss_n  # the slide's dry friction holds up to 5 N
        moved = sign * conveyor.displacement(data)
        assert (push - friction) / k * 0.99 <= moved <= (push + friction) / k * 1.01
        assert moved == pytest.approx(1.0e-4, rel=0.15)
        data.qfrc_applied[dof] = 0.0
        run.step(200)
        assert abs(conveyor.displacement(data)) <= friction / k * 1.01
    for c in range(cfg.cols):  # empty the pickup row, index once
        adr = scene.pot_qpos_adr[c]
        data.qpos[adr : adr + 3] = [0.4 + 0.05 * c, 0.1, -0.13]
    conveyor.start(data, data.time, 0.6)
    assert model_hold(scene) == (0.0, 0.0)  # the index profile alone drives the carriage
    assert conveyor.displacement(data) == 0.0
    run.step_until(data.time + 0.6)
    conveyor.apply(data, data.time)
    assert conveyor.hold_position() == pytest.approx(-cfg.row_pitch_m)
    assert model_hold(scene) == pytest.approx((k, cfg.conveyor_hold_damping_n_s_m))
    run.step(400)
    assert abs(conveyor.displacement(data)) < 2e-4
    assert data.ntree_awake == 1  # the hold lets it sleep (a passive force, no actuator)


def _pushed(cfg, seed, pushes=1):
    """A belt (no pots picked) pushed `pushes` times at the paper's 0.6 s index, 1.5 s at
    rest after each: the scene, its data, the carriage's largest lag behind its profile (m)
    and every pot's offset from its cell centre (x across, y along; m)."""
    scene = build_scene(cfg, seed=seed)
    data, drive = scene.make_data(), ConveyorDrive(scene)
    for _ in range(500):
        mujoco.mj_step(scene.model, data)
    lag = 0.0
    for _ in range(pushes):
        drive.start(data, data.time, 0.6)
        while drive.armed(data):
            drive.apply(data, data.time)
            q_ref, _ = drive.reference(data, data.time)
            lag = max(lag, abs(q_ref - drive.position(data)))
            mujoco.mj_step(scene.model, data)
        for _ in range(1500):
            mujoco.mj_step(scene.model, data)
    cells = scene.pots.cell_xy + [0.0, drive.position(data)]
    return scene, data, lag, scene.pot_positions(data)[:, :2] - cells


@pytest.mark.slow
@pytest.mark.parametrize("rows", [8, 24])
def test_the_stepper_index_follows_its_profile_whatever_the_pots_it_pushes(rows):
    """The "stepper" index drive (the hold's set point moved along the profile) lags it by
    less than 0.5 mm with 8 rows of pots or 24, and leaves the pots centred along the belt;
    the "pd" estimate lags by the pots' friction (about 3 mm with 24 rows) and leaves them
    ahead by its overshoot."""
    cfg = SceneConfig(rows=rows, live_rows=rows, conveyor_index_drive="stepper")
    scene, data, lag, offset = _pushed(cfg, seed=2)
    on_belt = slice(2 * cfg.cols, None)  # row 0 went off the edge, row 1 is its neighbour
    assert lag < 5e-4
    assert abs(offset[on_belt, 1].mean()) < 3e-4
    k, b = cfg.conveyor_hold_stiffness_n_m, cfg.conveyor_hold_damping_n_s_m
    assert model_hold(scene) == pytest.approx((k, b))  # the hold stayed on throughout
    assert scene.model.qpos_spring[scene.conveyor_qpos_adr] == pytest.approx(-cfg.row_pitch_m)
    if rows == 24:
        _, _, pd_lag, pd_offset = _pushed(replace(cfg, conveyor_index_drive="pd"), seed=2)
        assert pd_lag > 2e-3
        assert offset[on_belt, 1].mean() + 1e-3 < pd_offset[on_belt, 1].mean()


@pytest.mark.slow
@pytest.mark.parametrize("seed", [1, 2])
def test_pots_on_feet_are_pushed_alike_wherever_they_stand_on_the_table(seed):
    """On sphere feet a pushed pot ends where its cell leaves it, on the near half of the belt
    as on the far half (a cylinder on the table's box is pushed sideways by where it stands
    on it: +0.5 to +1 mm more on the far half after one push)."""
    cfg = SceneConfig(rows=24, live_rows=24, conveyor_index_drive="stepper", pot_feet=8)
    _, _, _, offset = _pushed(cfg, seed=seed)
    across = offset[:, 0].reshape(cfg.rows, cfg.cols)[2:]  # rows on the belt
    near, far = across[:11].mean(), across[11:].mean()
    assert abs(far - near) < 3e-4
    assert abs(across.mean()) < 4e-4


def _collide(m, g1, g2) -> bool:
    """MuJoCo's contype/conaffinity filter of two geoms."""
    return bool(m.geom_contype[g1] & m.geom_conaffinity[g2]) or bool(
        m.geom_contype[g2] & m.geom_conaffinity[g1]
    )


def test_only_the_feet_of_pots_on_feet_touch_the_table():
    """With pot_feet the table touches the pots' feet and bond pads, never their cylinders,
    which still pass the collision filter with every other geom they passed it with before;
    the feet touch the table only. The table's contype is unchanged, so the serial arm's links
    (contype 1, conaffinity 1) and the delta's (2, 1) still meet it. Every pot stands on its
    feet, as high as on its cylinder, crooked and bonded pots too."""
    cfg = SceneConfig(rows=3, cols=3, pot_feet=8, pot_crooked_share=0.4, pot_bond_share=0.5,
                      pot_bond_force_n=5.0)  # fmt: skip
    scene = build_scene(cfg, seed=4)
    cylinder = build_scene(replace(cfg, pot_feet=0), seed=4)
    m, m0 = scene.model, cylinder.model
    table = m.geom("belt_table").id
    assert m.geom_contype[table] == m0.geom_contype[m0.geom("belt_table").id]
    for contype, conaffinity in ((1, 1), (2, 1)):  # the serial arm's, the delta's collision class
        assert contype & m.geom_conaffinity[table] or m.geom_contype[table] & conaffinity
    named = [m0.geom(g).name for g in range(m0.ngeom) if m0.geom(g).name]
    for r in range(3):
        for c in range(3):
            pot = m.geom(f"pot_{r}_{c}").id
            assert not _collide(m, pot, table) and _collide(m0, m0.geom(f"pot_{r}_{c}").id, table)
            for name in named:
                if name != "belt_table" and not name.startswith("pot_base_"):  # pads: the table's
                    before = _collide(m0, m0.geom(f"pot_{r}_{c}").id, m0.geom(name).id)
                    assert _collide(m, pot, m.geom(name).id) == before, (r, c, name)
    feet = {m.geom(f"foot_{r}_{c}_{k}").id for r in range(3) for c in range(3) for k in range(8)}
    assert all(_collide(m, f, g) == (g == table) for f in feet for g in range(m.ngeom))
    data = scene.make_data()
    touching = set()
    for _ in range(300):  # the pots settle onto the table, then fall asleep
        mujoco.mj_step(m, data)
        for con in data.contact[: data.ncon]:
            pair = {int(con.geom1), int(con.geom2)}
            if table in pair:
                other = (pair - {table}).pop()
                assert other in feet or (m.geom(other).name or "").startswith("pot_base_")
                touching.add(int(m.body_rootid[m.geom_bodyid[other]]))
    pot_bodies = {m.body(f"pot_{r}_{c}").id for r in range(3) for c in range(3)}
    assert {int(m.geom_bodyid[f]) for f in feet} == pot_bodies
    assert touching == pot_bodies  # every pot on its feet
    data0 = cylinder.make_data()
    for _ in range(300):
        mujoco.mj_step(m0, data0)
    heights = scene.pot_positions(data)[:, 2]
    np.testing.assert_allclose(heights, cylinder.pot_positions(data0)[:, 2], atol=1e-4)
    assert np.abs(heights - scene.pots.height / 2).min() < 1e-4


def test_feet_and_index_drives_out_of_range_are_refused():
    for feet in (-1, 1, 2, 17, 8.0):
        with pytest.raises(ValueError, match="pot_feet"):
            SceneConfig(pot_feet=feet)
    with pytest.raises(ValueError, match="conveyor_index_drive must be one of pd, stepper"):
        SceneConfig(conveyor_index_drive="servo")


def model_hold(scene):
    m, dof = scene.model, scene.conveyor_dof_adr
    return float(m.jnt_stiffness[m.dof_jntid[dof]]), float(m.dof_damping[dof])


def test_bonded_pots_get_an_adhesion_pad_that_touches_only_the_belt_and_still_sleep():
    import dataclasses

    cfg = dataclasses.replace(
        SceneConfig(), pot_bond_share=0.5, pot_bond_force_n=5.0, pot_bond_sd_log=0.5
    )
    scene = build_scene(cfg, seed=3)
    m = scene.model
    bonded = np.flatnonzero(scene.pots.bond_force > 0)
    assert 5 < bonded.size < 35  # about half of 40
    assert m.nu == 5 + bonded.size
    assert sorted(scene.bond_pots) == list(bonded)
    np.testing.assert_allclose(
        m.actuator_gainprm[scene.bond_actuators, 0], scene.pots.bond_force[scene.bond_pots]
    )
    assert (m.actuator_trntype[scene.bond_actuators] == mujoco.mjtTrn.mjTRN_BODY).all()
    pad = m.geom(f"pot_base_{bonded[0] // 5}_{bonded[0] % 5}").id
    belt = m.geom("belt_table").id
    # the pad collides with the belt, and sits inside the pot's footprint at its base, where
    # nothing but the belt can touch it (the jaws grip the pot's side)
    assert m.geom_contype[pad] & m.geom_conaffinity[belt]
    assert m.geom_conaffinity[pad] == 0
    pot = m.geom(f"pot_{bonded[0] // 5}_{bonded[0] % 5}").id
    assert m.geom_size[pad, 0] < 0.8 * m.geom_size[pot, 0]
    base_z = m.body_pos[m.geom_bodyid[pad], 2] - m.geom_size[pad, 1]
    assert base_z == pytest.approx(-m.geom_size[pot, 1])  # flush with the pot's bottom
    data = scene.make_data()
    assert (data.ctrl[scene.bond_actuators] == 0).all()  # on only while the jaws pull
    for _ in range(2000):
        mujoco.mj_step(m, data)
    assert data.ntree_awake == 1  # the arm; every pot asleep, bonded or not


def test_bond_draws_leave_the_other_pot_draws_unchanged():
    import dataclasses

    plain = PotBatch.draw(SceneConfig(), 5)
    bonded = PotBatch.draw(
        dataclasses.replace(SceneConfig(), pot_bond_share=0.3, pot_bond_force_n=4.0), 5
    )
    for name in ("diameter", "height", "mass", "friction", "offset", "stem_length"):
        np.testing.assert_array_equal(getattr(plain, name), getattr(bonded, name))
    assert (plain.bond_force == 0).all()
    assert set(np.unique(bonded.bond_force)) >= {0.0, 4.0}  # sd_log 0: every bond 4 N


def test_a_vanishing_spread_draws_its_normal_limit_not_an_overflow():
    """pots.friction_sd = 1e-300 overflowed the gamma's shape (mean/sd)^2; below 1e-6 of the
    mean the gamma is drawn as its normal limit, which it equals to float precision."""
    from transplanter.scene.pots import gamma_of

    z = np.array([-2.0, 0.0, 1.5])
    np.testing.assert_array_equal(gamma_of(z, 0.6, 1e-300), [0.6, 0.6, 0.6])
    tiny = gamma_of(z, 0.6, 1e-9)
    np.testing.assert_allclose(tiny, 0.6 + 1e-9 * z, rtol=0, atol=1e-15)
    # just above the switch the gamma and its normal limit agree to float precision
    np.testing.assert_allclose(gamma_of(z, 0.6, 0.6 * 1.01e-6), 0.6 + 0.6 * 1.01e-6 * z, rtol=1e-9)
