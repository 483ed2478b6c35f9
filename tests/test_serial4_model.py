"""models/serial4: the serial 4-DOF servo arm of seed 004 in MuJoCo. It compiles, its servos
hold the park pose under gravity, joints from the pure kinematics' IK put the grip centre at
the FK point, the gripper servo opens the fingers by half its angle each, and the
rangefinders (sensor 2 on the gripper, sensor 1 at the pick station) read the distance to
what is in front of them and -1 where nothing is."""

from __future__ import annotations

import math
import warnings

import mujoco
import numpy as np
import pytest

from conftest import ROOT
from transplanter.machine.fuzzy_gripper import NO_ECHO, UltrasonicSensor
from transplanter.machine.kinematics.serial4 import Serial4Kinematics
from transplanter.machine.servo import MG996R, SG90

SCENE = ROOT / "models" / "serial4" / "scene.xml"
ARM = Serial4Kinematics()


def compile_scene(spec: mujoco.MjSpec | None = None) -> mujoco.MjModel:
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        return (spec or mujoco.MjSpec.from_file(str(SCENE))).compile()


def at_home(model):
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, model.key("home").id)
    mujoco.mj_forward(model, data)
    return data


def world_of(model, data, paper_xyz):
    """The paper's frame (x forward, y up, z to the right) in the world (z up): x, -z, y, from
    the shoulder axis."""
    shoulder = data.body("upper_arm").xpos
    x, y, z = np.asarray(paper_xyz, dtype=np.float64)
    return shoulder + np.array([x, -z, y])


def settle(model, data, ctrl, seconds):
    data.ctrl[:] = ctrl
    for _ in range(round(seconds / model.opt.timestep)):
        mujoco.mj_step(model, data)


def test_the_model_compiles_with_the_servo_classes():
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
    # the grip centre l2 ahead of and l1 above the shoulder
    np.testing.assert_allclose(
        data.site("grip_center").xpos, world_of(model, data, ARM.point(ARM.park_rad)), atol=1e-12
    )
    assert data.body("upper_arm").xpos[2] == pytest.approx(0.060)


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
    error = np.linalg.norm(data.site("grip_center").xpos - world_of(model, data, point))
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


def test_the_rangefinders_read_the_distance_to_a_box_and_minus_one_with_nothing():
    model = compile_scene()
    data = at_home(model)
    # nothing in front of either sensor (the gripper's ray is level at the park pose)
    assert data.sensor("gripper_range").data[0] == -1.0
    assert data.sensor("station_range").data[0] == -1.0
    sensor = data.site("gripper_sensor").xpos.copy()
    station = data.site("station_sensor").xpos.copy()
    # a box 250 mm ahead of the gripper's sensor, another on the pick station
    spec = mujoco.MjSpec.from_file(str(SCENE))
    add_box(spec, "target", [sensor[0] + 0.25 + 0.01, sensor[1], sensor[2]], [0.01, 0.03, 0.03])
    add_box(spec, "tomato", [station[0], 0.0, 0.03], [0.02, 0.02, 0.03])
    model = compile_scene(spec)
    data = at_home(model)
    assert data.sensor("gripper_range").data[0] == pytest.approx(0.25, abs=1e-3)
    assert data.sensor("station_range").data[0] == pytest.approx(station[1] - 0.02, abs=1e-3)
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
