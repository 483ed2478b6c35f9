"""models/effectors/fuzzy_gripper: the serial arm's gripper sized for tomatoes. Its file holds
FuzzyGripperConfig's defaults; the pads' gap measured on the compiled model is narrower than a
5 cm tomato at the fuzzy controller's Small (22.5 deg) and clears a 7 cm one at its standby
(48 deg); and on the arm, with the joints from the IK, it lifts a free 60 mm / 120 g and a
70 mm / 150 g sphere 40 mm by friction alone (no weld, no equality to the object) at about
the stall torque over the pads' lever."""

from __future__ import annotations

import math
import subprocess
import sys
import warnings
from dataclasses import replace

import mujoco
import numpy as np
import pytest

from conftest import ROOT
from transplanter.machine.kinematics.serial4 import Serial4Kinematics, fk
from transplanter.machine.servo import SG90
from transplanter.scenario.assemble import fuzzy_gripper_config
from transplanter.scenario.schema import SCHEMA, ScenarioError, load_scenario
from transplanter.scene import kinds
from transplanter.scene.effectors import fuzzy_gripper
from transplanter.scene.effectors.fuzzy_gripper import FuzzyGripperConfig, pad_gap_m, reach_m
from transplanter.scene.serial_scene import (
    SHOULDER_HEIGHT_M,
    SerialSceneConfig,
    build_serial_spec,
    compile_scene,
    home_ctrl,
    home_qpos,
    paper_to_world,
)

FOLDER = ROOT / "models" / "effectors" / "fuzzy_gripper"
ARM = Serial4Kinematics()


def test_the_meshes_are_up_to_date():
    run = subprocess.run(
        [sys.executable, str(ROOT / "scripts" / "make_fuzzy_gripper_meshes.py"), "--check"],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert run.returncode == 0, run.stdout + run.stderr


def test_the_file_holds_the_configs_defaults():
    """apply() with the defaults changes nothing the file says."""
    spec = mujoco.MjSpec.from_file(str(FOLDER / "fuzzy_gripper.xml"))
    before = mujoco.MjModel.from_xml_path(str(FOLDER / "fuzzy_gripper.xml"))
    kinds.effector("fuzzy_gripper").apply(spec, FuzzyGripperConfig())
    after = spec.compile()
    for attr in ("body_pos", "geom_pos", "geom_quat", "geom_size", "geom_friction", "site_pos",
                 "body_mass", "dof_damping", "dof_armature", "actuator_gainprm",
                 "actuator_biasprm", "actuator_forcerange"):  # fmt: skip
        np.testing.assert_allclose(getattr(after, attr), getattr(before, attr), atol=1e-12,
                                   err_msg=attr)  # fmt: skip
    assert before.site("grip_center").pos[0] == pytest.approx(reach_m(FuzzyGripperConfig()))
    assert sum(before.body_mass) == pytest.approx(0.0395)  # tens of grams


def pad_gap(model, data) -> float:
    """Distance between the centres of the pads' faces (the faces that touch the object)."""
    faces = []
    for name, side in (("finger_left_pad", -1.0), ("finger_right_pad", 1.0)):
        g = data.geom(name)
        half = model.geom(name).size[1]
        faces.append(g.xpos + g.xmat.reshape(3, 3) @ np.array([0.0, side * half, 0.0]))
    return float(np.linalg.norm(faces[0] - faces[1]))


def test_the_pads_gap_fits_the_tomatoes_at_the_controllers_angles():
    model = mujoco.MjModel.from_xml_path(str(FOLDER / "fuzzy_gripper.xml"))
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, model.key("home").id)
    cfg = FuzzyGripperConfig()
    gaps = {}
    for deg in (22.5, 48.0, 20.0, 25.0, 60.0):
        data.ctrl[0] = math.radians(deg)
        for _ in range(500):
            mujoco.mj_step(model, data)
        gaps[deg] = pad_gap(model, data)
        assert gaps[deg] == pytest.approx(pad_gap_m(cfg, math.radians(deg)), abs=0.3e-3)
    assert gaps[22.5] < 0.050 and gaps[25.0] < 0.050  # Small: narrower than a 5 cm tomato
    assert gaps[48.0] > 0.075  # the standby clears a 7 cm one
    assert pad_gap_m(cfg, math.radians(48)) > 0.080
    # the servo's numbers: the SG90 class, its torque at the servo shaft (gear 2)
    act = model.actuator("gripper")
    assert act.gear[0] == 2 and act.forcerange[1] == pytest.approx(SG90.stall_torque_nm)
    assert act.gainprm[0] == pytest.approx(SG90.position_gain())


def hold(diameter_m, mass_kg, x_m=0.12):
    """The arm at the IK joints of a sphere resting on the floor x_m ahead of the shoulder (set
    directly, no firmware), the sphere free between the open fingers; the gripper commanded to
    22.5 deg, then the shoulder ctrl ramped over 0.5 s to lift the grip centre 40 mm, then 1 s
    held. Returns the squeeze (sum of the pads' contact normal forces) after the lift, how far
    the sphere rose, and its largest distance from grip_center while held."""
    from scipy.optimize import brentq

    cfg = SerialSceneConfig()
    spec = build_serial_spec(cfg)
    r = diameter_m / 2
    target = np.array([x_m, r - SHOULDER_HEIGHT_M, 0.0])
    q = ARM.require(target)[0]
    body = spec.worldbody.add_body(name="tomato", pos=paper_to_world(target).tolist())
    body.add_freejoint()
    body.add_geom(type=mujoco.mjtGeom.mjGEOM_SPHERE, size=[r, 0, 0], mass=mass_kg,
                  friction=[0.5, 0.005, 0.0001], condim=4)  # fmt: skip
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        model = compile_scene(spec)
    data = mujoco.MjData(model)
    data.qpos[:] = home_qpos(model, cfg)
    data.qpos[:3] = q  # base, shoulder, elbow come first
    data.ctrl[:] = home_ctrl(model, cfg)
    data.ctrl[:3] = q
    mujoco.mj_forward(model, data)

    def run(seconds):
        for _ in range(round(seconds / model.opt.timestep)):
            mujoco.mj_step(model, data)

    run(0.3)
    data.ctrl[3] = math.radians(22.5)
    run(0.5)
    z0 = data.body("tomato").xpos[2]
    y0 = fk(ARM.geometry, q)[1]
    lift = brentq(lambda a: fk(ARM.geometry, [q[0], q[1] + a, q[2]])[1] - y0 - 0.040, 0, 1)
    start, n = data.ctrl[1], round(0.5 / model.opt.timestep)
    for k in range(n):
        data.ctrl[1] = start + lift * (k + 1) / n
        mujoco.mj_step(model, data)
    worst = 0.0
    for _ in range(round(1.0 / model.opt.timestep)):
        mujoco.mj_step(model, data)
        offset = data.body("tomato").xpos - data.site("grip_center").xpos
        worst = max(worst, float(np.linalg.norm(offset)))
    pads = {model.geom("finger_left_pad").id, model.geom("finger_right_pad").id}
    tomato = model.body("tomato").id
    force, squeeze = np.zeros(6), 0.0
    for i in range(data.ncon):
        c = data.contact[i]
        if {c.geom1, c.geom2} & pads and tomato in model.geom_bodyid[[c.geom1, c.geom2]]:
            mujoco.mj_contactForce(model, data, i, force)
            squeeze += force[0]
    return squeeze, data.body("tomato").xpos[2] - z0, worst


@pytest.mark.parametrize("diameter_mm, mass_g", [(60, 120), (70, 150)])
def test_the_gripper_lifts_a_tomato_by_friction_alone(diameter_mm, mass_g):
    squeeze, rise, worst = hold(diameter_mm * 1e-3, mass_g * 1e-3)
    assert rise > 0.035  # it rose with the fingers (the servos droop a little under the load)
    assert worst < 0.005  # and stayed at the grip centre
    # the servo at its stall torque on each finger, over the pads' ~78 mm lever
    expected = 2 * SG90.stall_torque_nm / 0.078
    assert squeeze == pytest.approx(expected, rel=0.1)


def test_an_unknown_servo_or_a_grip_wider_than_the_standby_is_refused():
    with pytest.raises(ValueError, match="unknown servo class 'ds3218'"):
        FuzzyGripperConfig(servo="ds3218")
    with pytest.raises(ValueError, match="grip_angle_deg < open_angle_deg"):
        FuzzyGripperConfig(grip_angle_deg=50)
    with pytest.raises(fuzzy_gripper.GripperNotInScene, match="gripper_mount"):
        fuzzy_gripper.apply(mujoco.MjSpec(), FuzzyGripperConfig())


def test_the_scenario_section_defaults_to_the_config_and_gives_back_what_is_set():
    from dataclasses import fields

    sc = load_scenario("paper")
    assert fuzzy_gripper_config(sc) == FuzzyGripperConfig()
    assert {f.name for f in fields(FuzzyGripperConfig)} - {"servo"} == set(SCHEMA["fuzzy_gripper"])
    sc = load_scenario("serial_arm", {"fuzzy_gripper.finger_length_mm": 85.5,
                                 "fuzzy_gripper.finger_mass_g": 7.5,
                                 "fuzzy_gripper.open_angle_deg": 50,
                                 "serial4.gripper_servo": "mg996r"})  # fmt: skip
    assert sc.fuzzy_gripper.finger_length_m == pytest.approx(0.0855)
    assert sc.fuzzy_gripper.finger_mass_kg == pytest.approx(0.0075)
    cfg = fuzzy_gripper_config(sc)
    assert (cfg.finger_length_mm, cfg.finger_mass_g, cfg.open_angle_deg) == (85.5, 7.5, 50)
    assert cfg.servo == "mg996r"
    with pytest.raises(ScenarioError, match="fuzzy_gripper.grip_angle_deg must be below"):
        load_scenario("serial_arm", {"fuzzy_gripper.grip_angle_deg": 48})
    # the scene takes them
    model = compile_scene(build_serial_spec(replace(SerialSceneConfig(), gripper=cfg)))
    assert model.geom("finger_left_beam").size[0] == pytest.approx((0.0855 + 0.012 + 0.004) / 2)
