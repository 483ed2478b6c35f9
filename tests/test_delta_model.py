"""The rotary delta's MJCF model (models/delta/) on its own: the file is what
scripts/make_delta_model.py writes, its home keyframe closes the six rods' chains where the pure
kinematics puts the platform, the servos hold it under gravity with the torques of the paper's
Eq. 9, and commanding IK joint angles moves the platform onto the trays' cells (MuJoCo's platform
at the FK of its measured joints, level with the base)."""

from __future__ import annotations

import importlib.util
import math
import warnings

import mujoco
import numpy as np
import pytest

from conftest import ROOT
from transplanter.machine.kinematics.delta import DeltaKinematics

MODEL_DIR = ROOT / "models" / "delta"
KIN = DeltaKinematics()
GEAR = KIN.drives[0].ratio
MM = 1e-3


def make_delta_model():
    path = ROOT / "scripts" / "make_delta_model.py"
    spec = importlib.util.spec_from_file_location("make_delta_model", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.fixture(scope="module")
def model() -> mujoco.MjModel:
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        return mujoco.MjModel.from_xml_path(str(MODEL_DIR / "scene.xml"))


def hinge_q(model, data) -> np.ndarray:
    return np.array([data.joint(f"q{i}").qpos[0] for i in (1, 2, 3)])


def tilt_deg(data) -> float:
    """Angle between the platform's z axis and the world's (the base's) z axis."""
    return math.degrees(math.acos(min(1.0, data.body("platform").xmat[8])))


def closure_mm(model, data) -> float:
    """Largest gap between a rod's end and its platform site."""
    gaps = [
        np.linalg.norm(data.site(f"rod{i}{s}_end").xpos - data.site(f"c{i}{s}").xpos)
        for i in (1, 2, 3)
        for s in "ab"
    ]
    return max(gaps) / MM


def test_the_file_is_what_the_script_writes():
    """The same text, and the same numbers but in their last bits (numpy's matrix products
    leave those to the CPU's BLAS kernel)."""
    script = make_delta_model()
    assert script.same_model((MODEL_DIR / "delta.xml").read_text(), script.xml())


def test_the_file_check_tells_a_last_bit_from_a_change():
    same_model = make_delta_model().same_model
    text = (MODEL_DIR / "delta.xml").read_text()
    last_bit = text.replace("-0.7871415607974807", "-0.7871415607974808", 1)
    assert last_bit != text and same_model(text, last_bit)
    assert not same_model(text, text.replace("-0.7871415607974807", "-0.7871415607975807", 1))
    assert not same_model(text, text.replace('class="rod"', 'class="rods"', 1))


def test_the_model_is_a_closed_chain_not_a_weld(model):
    # three arm hinges, two universal joints per rod, the platform's free joint
    assert model.njnt == 3 + 12 + 1
    assert model.nu == 3
    types = {mujoco.mjtEq(t).name for t in model.eq_type}
    assert types == {"mjEQ_CONNECT"} and model.neq == 6
    assert model.body("platform").id not in {model.eq_obj1id[0], -1}
    # the estimated masses of docs/delta.md: arms, elbows, rods, platform
    masses = {name: model.body(name).mass[0] for name in ("upper_arm1", "rod1a", "platform")}
    assert masses["upper_arm1"] == pytest.approx(0.30 + 0.05)
    assert masses["rod1a"] == pytest.approx(0.10)
    assert masses["platform"] == pytest.approx(1.00)
    # servo: 12 N m at the joint through the 25:1 reducer
    np.testing.assert_allclose(model.actuator_forcerange * GEAR, [[-12.0, 12.0]] * 3)
    np.testing.assert_allclose(model.actuator_gear[:, 0], GEAR)
    np.testing.assert_allclose(model.dof_armature[0], 1.5e-4 * GEAR**2)


def test_home_keyframe_closes_the_chains_at_the_kinematics_pose(model):
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, model.key("home").id)
    mujoco.mj_forward(model, data)
    q = hinge_q(model, data)
    assert np.ptp(q) == 0.0
    np.testing.assert_allclose(q, KIN.joints([0.0, 0.0, -0.8]), atol=1e-15)
    np.testing.assert_allclose(data.body("platform").xpos, [0.0, 0.0, -0.8], atol=1e-15)
    assert closure_mm(model, data) < 1e-9
    np.testing.assert_allclose(data.ctrl, GEAR * q)


def test_the_servos_hold_home_under_gravity_with_eq9s_torques(model):
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, model.key("home").id)
    for _ in range(3000):
        mujoco.mj_step(model, data)
    platform = data.body("platform").xpos
    q = hinge_q(model, data)
    assert np.abs(data.qvel).max() < 1e-6  # settled
    # the position loops sag by torque / stiffness (2.73 N m at 120 N m/deg is 0.023 deg)
    sag_mm = (platform[2] + 0.8) / MM
    assert -0.3 < sag_mm < -0.1
    assert np.abs(platform[:2]).max() < 1e-9
    assert np.abs(KIN.point(q) - platform).max() / MM < 0.01
    assert tilt_deg(data) < 1e-6
    # the motors hold exactly the static torque of the paper's Eq. 9 (signs restored)
    torque = data.actuator_force * GEAR
    np.testing.assert_allclose(torque, KIN.gravity_torques(q), rtol=1e-4)
    assert torque[0] == pytest.approx(-2.7317, abs=1e-3)


CELLS_MM = [
    (0.0, 0.0, -800.0),
    (247.7, 285.1, -800.0),  # far corner cells of both trays (16 x 8 cells, Y0 = +-160 mm)
    (-247.7, -285.1, -800.0),
    (247.7, -285.1, -800.0),
    (-247.7, 285.1, -650.0),  # above a corner at the 150 mm clearance height
    (200.0, 200.0, -800.0),  # the paper's example move
    (250.0, -175.0, -800.0),
]


def test_commanded_ik_angles_move_the_platform_onto_the_cells(model):
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, model.key("home").id)
    mujoco.mj_forward(model, data)
    move, steps = int(0.6 / model.opt.timestep), int(1.0 / model.opt.timestep)
    worst = {"fk": 0.0, "target": 0.0, "tilt": 0.0, "closure": 0.0, "torque": 0.0}
    for cell in CELLS_MM:
        target = np.array(cell) * MM
        assert KIN.check(target).ok.all()
        start, goal = data.ctrl.copy(), GEAR * KIN.joints(target)
        # a smooth 0.6 s move in motor angles, then 0.4 s of settling (corner to corner in
        # 0.4 s asks more than 12 N m of arm 3, and the saturated position loop then rings)
        for k in range(steps):
            s = min(1.0, (k + 1) / move)
            data.ctrl[:] = start + (goal - start) * (3 * s * s - 2 * s * s * s)
            mujoco.mj_step(model, data)
            worst["tilt"] = max(worst["tilt"], tilt_deg(data))
            worst["closure"] = max(worst["closure"], closure_mm(model, data))
            worst["torque"] = max(worst["torque"], np.abs(data.actuator_force).max() * GEAR)
        platform = data.body("platform").xpos
        worst["fk"] = max(worst["fk"], np.abs(KIN.point(hinge_q(model, data)) - platform).max())
        worst["target"] = max(worst["target"], np.linalg.norm(platform - target))
    assert worst["fk"] / MM < 0.5  # MuJoCo's platform is where FK puts it
    assert worst["target"] / MM < 1.0  # the servos' sag under gravity
    assert worst["tilt"] < 0.5  # the parallelograms keep the platform level
    assert worst["closure"] < 0.1
    assert worst["torque"] <= 12.0 + 1e-9
