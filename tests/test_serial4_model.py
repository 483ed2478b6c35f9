"""models/serial4 with the fuzzy gripper attached, as transplanter.scene.serial_scene builds it:
it compiles with the servo classes the scenario names, grip_center lies where the pure
kinematics' FK puts it for any link lengths, its servos hold the park pose under gravity,
joints from the IK put the grip centre at the FK point, the gripper servo opens the fingers by
half its angle each, and the gripper's rangefinder reads the distance to what is in front of
it and -1 where nothing is."""

from __future__ import annotations

import math
import warnings

import mujoco
import numpy as np
import pytest

from transplanter.machine.fuzzy_gripper import NO_ECHO, UltrasonicSensor
from transplanter.machine.kinematics.serial4 import Serial4Geometry, Serial4Kinematics, fk
from transplanter.machine.servo import MG996R, SG90
from transplanter.scenario.schema import load_scenario
from transplanter.scene import serial_scene
from transplanter.scene.effectors.fuzzy_gripper import FuzzyGripperConfig, reach_m
from transplanter.scene.serial_scene import (
    SHOULDER_HEIGHT_M,
    SerialSceneConfig,
    build_serial_spec,
    home_ctrl,
    home_qpos,
    paper_to_world,
    serial_scene_config,
    world_to_paper,
)

ARM = Serial4Kinematics()


def compile_scene(spec: mujoco.MjSpec | None = None, cfg=None) -> mujoco.MjModel:
    """Compile a scene; any MuJoCo warning fails the test."""
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        return serial_scene.compile_scene(spec or build_serial_spec(cfg or SerialSceneConfig()))


def at_home(model, cfg=None):
    cfg = cfg or SerialSceneConfig()
    data = mujoco.MjData(model)
    data.qpos[:] = home_qpos(model, cfg)
    data.ctrl[:] = home_ctrl(model, cfg)
    mujoco.mj_forward(model, data)
    return data


def settle(model, data, ctrl, seconds):
    data.ctrl[:] = ctrl
    for _ in range(round(seconds / model.opt.timestep)):
        mujoco.mj_step(model, data)


def test_the_scene_compiles_with_the_servo_classes():
    model = compile_scene()
    assert [model.actuator(i).name for i in range(model.nu)] == [
        "base", "shoulder", "elbow", "gripper",
    ]  # fmt: skip
    for name, servo in (("base", SG90), ("shoulder", MG996R), ("elbow", MG996R)):
        act = model.actuator(name)
        assert act.forcerange[1] == pytest.approx(servo.stall_torque_nm)
        assert act.gainprm[0] == pytest.approx(servo.position_gain())
        assert model.joint(name).damping[0] == pytest.approx(
            servo.stall_torque_nm / servo.speed_rad_s
        )
        # the actuator's range is the kinematics' joint window
        lo, hi = ARM.axes[["base", "shoulder", "elbow"].index(name)].window
        np.testing.assert_allclose(act.ctrlrange, [lo, hi])
    data = at_home(model)
    np.testing.assert_allclose(data.qpos[:3], ARM.park_rad)
    # the grip centre l2 ahead of and l1 above the shoulder, the gripper open 48 deg
    np.testing.assert_allclose(
        data.site("grip_center").xpos, paper_to_world(ARM.point(ARM.park_rad)), atol=1e-12
    )
    assert data.body("upper_arm").xpos[2] == pytest.approx(SHOULDER_HEIGHT_M)
    assert data.ctrl[3] == pytest.approx(math.radians(48))
    assert data.joint("finger_left").qpos[0] == pytest.approx(math.radians(24))


def test_the_robot_xml_ends_at_the_tool_mount():
    model = compile_scene(mujoco.MjSpec.from_file(str(serial_scene.models_dir() / "serial4" /
                                                      "serial4.xml")))  # fmt: skip
    assert model.nu == 3 and model.nq == 3 and model.key("home").qpos.size == 3
    assert model.site("tool_mount").id >= 0
    forearm = model.site("tool_mount").pos[0]
    assert forearm == pytest.approx(0.080 - reach_m(FuzzyGripperConfig()))


@pytest.mark.parametrize("l1_l2_mm", [(80, 80), (100, 120), (70, 75)])
def test_grip_center_sits_where_the_kinematics_puts_it_for_any_link_lengths(l1_l2_mm):
    l1, l2 = (v * 1e-3 for v in l1_l2_mm)
    model = compile_scene(cfg=SerialSceneConfig(l1_m=l1, l2_m=l2))
    data = mujoco.MjData(model)
    geom = Serial4Geometry(l1_m=l1, l2_m=l2)
    rng = np.random.default_rng(4)
    for joints in rng.uniform([-1.5, 0.1, -2.5], [1.5, 2.5, 0.2], size=(20, 3)):
        data.qpos[:3] = joints
        mujoco.mj_forward(model, data)
        error = np.linalg.norm(data.site("grip_center").xpos - paper_to_world(fk(geom, joints)))
        assert error < 1e-6, (joints, error)


def test_an_l2_shorter_than_the_grippers_reach_is_refused_naming_the_keys():
    reach = reach_m(FuzzyGripperConfig())
    build_serial_spec(SerialSceneConfig(l2_m=reach))  # a forearm of nothing: the servo horn
    needle = r"serial4\.l2_mm = 60 mm is shorter than the effector's reach \(70\.0235 mm"
    with pytest.raises(ValueError, match=needle + ".*finger_length_mm"):
        build_serial_spec(SerialSceneConfig(l2_m=0.060))


def test_the_scenarios_servo_classes_change_the_physics():
    sc = load_scenario(
        "serial_arm",
        {"serial4.shoulder_servo": "sg90", "serial4.l1_mm": 90, "serial4.gripper_servo": "sg90"},
    )
    cfg = serial_scene_config(sc)
    assert cfg.servos == ("sg90", "sg90", "mg996r", "sg90") and cfg.l1_m == pytest.approx(0.09)
    assert cfg.timestep_s == sc.physics.timestep_s
    model = compile_scene(cfg=cfg)
    act = model.actuator("shoulder")
    assert act.forcerange[1] == pytest.approx(SG90.stall_torque_nm)
    assert act.gainprm[0] == pytest.approx(SG90.position_gain())
    assert model.joint("shoulder").damping[0] == pytest.approx(
        SG90.stall_torque_nm / SG90.speed_rad_s
    )
    assert model.joint("shoulder").armature[0] == pytest.approx(0.0002)
    assert model.body("forearm").pos[0] == pytest.approx(0.09)
    default = compile_scene()
    assert default.actuator("shoulder").forcerange[1] == pytest.approx(MG996R.stall_torque_nm)


def test_paper_and_world_frames():
    p = np.array([[0.1, 0.04, 0.05], [0.0, 0.0, 0.0]])
    np.testing.assert_allclose(paper_to_world(p), [[0.1, -0.05, 0.1], [0, 0, 0.06]])
    np.testing.assert_allclose(world_to_paper(paper_to_world(p)), p)


def test_a_workcell_is_merged_applied_and_populated():
    """The workcell's world (models/workcells/<MODEL>) merged with the arm, its `apply` and
    `populate` run: the pool_to_belt cell brings its ground (no second floor), sensor 1, the
    belt and the seed's tomatoes."""
    from transplanter.scene.workcells.pool_to_belt import PoolToBeltConfig, draw_tomatoes

    pool = PoolToBeltConfig(count=2)
    cfg = SerialSceneConfig(workcell_kind="pool_to_belt", workcell=pool)
    model = compile_scene(build_serial_spec(cfg, seed=7))
    planes = [g for g in range(model.ngeom) if model.geom_type[g] == mujoco.mjtGeom.mjGEOM_PLANE]
    assert len(planes) == 1
    assert model.site("station_sensor").id >= 0 and model.joint("belt").id >= 0
    drawn = draw_tomatoes(pool, 7)
    for t in drawn:
        assert model.body(t.name).mass[0] == pytest.approx(t.mass_kg)
    assert mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, "tomato02") == -1


def test_the_servos_hold_the_park_pose_under_gravity():
    model = compile_scene()
    data = at_home(model)
    start = data.site("grip_center").xpos.copy()
    settle(model, data, data.ctrl.copy(), 2.0)
    assert np.abs(data.qvel).max() < 1e-4
    sag = np.degrees(np.abs(data.qpos[:3] - np.array(ARM.park_rad)))
    assert sag.max() < 0.2  # servo stiffness: the stall torque at 3 deg of error
    assert np.linalg.norm(data.site("grip_center").xpos - start) < 0.5e-3


TARGETS_CM = [(9, 2, 0), (9, 6, 1), (10, 4, 5), (12, 4, 5), (6, 10, -4), (14, 0, -3)]


@pytest.mark.parametrize("target", TARGETS_CM, ids=[str(t) for t in TARGETS_CM])
def test_ik_joints_put_the_grip_centre_at_the_fk_point(target):
    model = compile_scene()
    data = at_home(model)
    point = np.array(target) * 0.01
    joints = ARM.require(point)[0]
    settle(model, data, [*joints, data.ctrl[3]], 1.5)
    error = np.linalg.norm(data.site("grip_center").xpos - paper_to_world(point))
    assert error < 2e-3, error  # the servos' droop under the arm's weight
    np.testing.assert_allclose(data.qpos[:3], joints, atol=math.radians(0.5))


def test_the_gripper_servo_opens_each_finger_by_half_its_angle():
    model = compile_scene()
    data = at_home(model)
    for theta4_deg in (0.0, 22.5, 60.0):
        ctrl = data.ctrl.copy()
        ctrl[3] = math.radians(theta4_deg)
        settle(model, data, ctrl, 0.5)
        half = math.radians(theta4_deg) / 2
        assert data.joint("finger_left").qpos[0] == pytest.approx(half, abs=math.radians(0.2))
        assert data.joint("finger_right").qpos[0] == pytest.approx(half, abs=math.radians(0.2))


def add_box(spec, name, pos, half):
    body = spec.worldbody.add_body(name=name, pos=pos)
    body.add_geom(type=mujoco.mjtGeom.mjGEOM_BOX, size=half, rgba=[0.8, 0.2, 0.2, 1])


def test_the_rangefinder_reads_the_distance_to_a_box_and_minus_one_with_nothing():
    model = compile_scene()
    data = at_home(model)
    # nothing in front of the sensor (its ray is level at the park pose)
    assert data.sensor("gripper_range").data[0] == -1.0
    sensor = data.site("gripper_sensor").xpos.copy()
    np.testing.assert_allclose(data.site("gripper_sensor").xmat.reshape(3, 3)[:, 2], [1, 0, 0],
                               atol=1e-12)  # fmt: skip
    # a box 250 mm ahead of the gripper's sensor
    spec = build_serial_spec(SerialSceneConfig())
    add_box(spec, "target", [sensor[0] + 0.25 + 0.01, sensor[1], sensor[2]], [0.01, 0.03, 0.03])
    model = compile_scene(spec)
    data = at_home(model)
    assert data.sensor("gripper_range").data[0] == pytest.approx(0.25, abs=1e-3)
    # through the HC-SR04 model: in cm for the fuzzy controller
    hc = UltrasonicSensor()
    assert hc.reading_cm(data.sensor("gripper_range").data) == pytest.approx(25.0, abs=0.1)


def test_a_drooping_gripper_sees_the_far_floor_which_the_sensor_model_drops():
    """After the servos settle under gravity the forearm dips a fraction of a degree, and its
    level ray meets the floor tens of metres away: MuJoCo reads that distance, the HC-SR04
    (4 m range) hears no echo."""
    model = compile_scene()
    data = at_home(model)
    settle(model, data, data.ctrl.copy(), 1.0)
    far = data.sensor("gripper_range").data[0]
    assert far == -1.0 or far > 4.0
    assert UltrasonicSensor().reading(far) == NO_ECHO
