"""transplanter.scene.robots.gantry and models/gantry/: the gantry's scene on the pot line,
its slides' qpos the grip centre's coordinates, its steppers' gears from the belt's and the
screw's leads, its switches at the ends of the travel, and the file holding the defaults."""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest

from conftest import ROOT
from transplanter.scenario.assemble import assemble
from transplanter.scenario.schema import load_scenario
from transplanter.scene import build_scene
from transplanter.scene.robots.gantry import GantryParams, gears

GANTRY_XML = ROOT / "models" / "gantry" / "gantry.xml"


@pytest.fixture(scope="module")
def config():
    small = {"conveyor.rows": 2, "scenario.seedlings": 10}
    return assemble(load_scenario("gantry_pots", small)).scene


@pytest.fixture(scope="module")
def scene(config):
    return build_scene(config, seed=1)


def test_the_scenario_gives_the_scene_its_gantry(config):
    p = config.robot_params
    assert isinstance(p, GantryParams)
    assert p.x_window_m == pytest.approx((-0.150, 0.150))
    # power-on: 10 mm short of each switch, against homing (X and Y low, Z up)
    assert p.power_on_m == pytest.approx((-0.140, 0.050, 0.150))


def test_each_slide_is_the_grip_centre_coordinate(scene):
    model = scene.model
    data = mujoco.MjData(model)
    for x, y, z in ((-0.09, 0.215, 0.034), (0.0, 0.140, 0.060), (0.12, 0.06, 0.150)):
        data.qpos[scene.motor_qpos_adr] = (x, y, z)
        mujoco.mj_kinematics(model, data)
        np.testing.assert_allclose(data.site_xpos[scene.grip_site], (x, y, z), atol=1e-12)


def test_the_steppers_turn_through_their_leads(scene, config):
    model = scene.model
    belt, screw = 2 * math.pi / 0.040, 2 * math.pi / 0.008
    np.testing.assert_allclose(scene.motor_gears, (belt, belt, screw))
    np.testing.assert_allclose(scene.motor_gears, gears(config))
    for name, gear in zip(("x", "y", "z"), scene.motor_gears, strict=True):
        dof = model.joint(name).dofadr[0]
        assert model.dof_armature[dof] == pytest.approx(config.rotor_inertia_kgm2 * gear**2)
    # the guides' friction on X and Y; the screw's on Z from the weight it lifts
    assert model.dof_frictionloss[model.joint("x").dofadr[0]] == pytest.approx(3.0)
    lifted = model.body_subtreemass[model.body("ram").id] * 9.81
    z_friction = model.dof_frictionloss[model.joint("z").dofadr[0]]
    assert z_friction == pytest.approx(lifted * (1 / 0.35 - 1), rel=1e-3)
    # the moving masses: the ram and jaws, the carriage, the bridge
    assert model.body_subtreemass[model.body("bridge").id] == pytest.approx(
        1.2 + 0.6 + model.body_subtreemass[model.body("ram").id]
    )


def test_the_switches_trip_at_the_ends_of_the_travel(scene):
    model = scene.model
    data = scene.make_data()
    assert scene.limit_switches(data).tolist() == [False, False, False, False]
    data.qpos[scene.motor_qpos_adr] = (-0.150, 0.040, 0.160)
    assert scene.limit_switches(data).tolist() == [True, True, True, False]
    data.qpos[scene.motor_qpos_adr] = (-0.1499, 0.0401, 0.005)
    assert scene.limit_switches(data).tolist() == [False, False, False, True]
    assert model.body(scene.robot_root).name == "bridge"


def test_the_portal_is_drawn_only(scene):
    model = scene.model
    robot = [
        g for g in range(model.ngeom)
        if model.body(model.geom_bodyid[g]).name in ("bridge", "carriage", "ram")
    ]  # fmt: skip
    assert robot and all(model.geom_contype[g] == 0 == model.geom_conaffinity[g] for g in robot)


def test_the_file_holds_the_defaults():
    """The numbers in models/gantry/gantry.xml are the default [gantry]'s as the scene applies
    them (a changed default must be written into the file)."""
    from transplanter.scene.config import SceneConfig
    from transplanter.scene.robots import gantry

    spec = mujoco.MjSpec.from_file(str(GANTRY_XML))
    model = spec.compile()
    cfg = SceneConfig(robot_kind="gantry", robot_params=GantryParams())
    gantry.apply(spec, cfg)
    applied = spec.compile()
    for field in (
        "jnt_range", "dof_armature", "dof_frictionloss", "actuator_gear", "actuator_biasprm",
        "actuator_ctrllimited", "actuator_forcelimited", "geom_size", "geom_pos", "body_mass",
        "numeric_data",
    ):  # fmt: skip
        np.testing.assert_array_equal(getattr(applied, field), getattr(model, field), field)
    # the screw's friction: the default scene's, with the jaws on the ram (apply_inertials)
    from transplanter.scene.build import robot_model

    attached = robot_model(cfg)
    z = attached.joint("z").dofadr[0]
    assert model.dof_frictionloss[model.joint("z").dofadr[0]] == attached.dof_frictionloss[z]
    home = model.key("home")
    np.testing.assert_allclose(home.qpos, GantryParams().power_on_m)
