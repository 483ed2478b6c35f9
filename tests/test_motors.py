"""The drives' meter (transplanter.twin.motors): peak force and positive mechanical work from
MuJoCo's actuator forces and velocities, checked against a model whose answer is known."""

import math

import mujoco
import numpy as np
import pytest

from transplanter.scenario.schema import load_scenario
from transplanter.twin.motors import BLOCK_STEPS, MotorMeter, drive_actuators, motor_columns

WHEEL = """
<mujoco>
  <option timestep="0.001" gravity="0 0 0" integrator="implicitfast"/>
  <worldbody>
    <body name="wheel">
      <joint name="spin" type="hinge" axis="0 0 1" armature="0.02"/>
      <geom type="cylinder" size="0.1 0.01" mass="1e-6"/>
    </body>
    <body name="cart" pos="1 0 0">
      <joint name="slide" type="slide" axis="1 0 0"/>
      <geom type="box" size="0.05 0.05 0.05" mass="2"/>
    </body>
    <body name="nut" pos="2 0 0">
      <joint name="screw" type="slide" axis="1 0 0"/>
      <geom type="box" size="0.05 0.05 0.05" mass="1"/>
    </body>
  </worldbody>
  <actuator>
    <motor name="spin" joint="spin" gear="4"/>
    <motor name="push" joint="slide"/>
    <motor name="lead" joint="screw" gear="785"/>
    <motor name="other" joint="spin"/>
  </actuator>
</mujoco>
"""


def _wheel():
    model = mujoco.MjModel.from_xml_string(WHEEL)
    return model, mujoco.MjData(model)


def test_work_of_a_constant_torque_is_the_kinetic_energy_it_gives():
    model, data = _wheel()
    meter = MotorMeter(model, ["spin"], ["push"])
    steps = 3 * BLOCK_STEPS + 17  # blocks and a partial one
    data.ctrl[:] = [0.05, 3.0, 0.0, 0.0]  # 0.2 N m at the joint, 3 N on the 2 kg cart
    for _ in range(steps):
        mujoco.mj_step(model, data)
        meter.record(data)
    r = meter.report()
    assert r.names == ("spin", "push") and r.robot == (True, False)
    assert r.linear == (False, True)
    assert r.peak == pytest.approx((0.05, 3.0))
    wheel_ke = 0.5 * 0.02 * data.qvel[0] ** 2
    cart_ke = 0.5 * 2.0 * data.qvel[1] ** 2
    assert wheel_ke > 0.01 and cart_ke > 0.1
    # the step's power is the force times the velocity at the step's end: one step's worth
    # more than the kinetic energy, no more
    assert r.work_j[0] == pytest.approx(wheel_ke, rel=2.0 / steps)
    assert r.work_j[1] == pytest.approx(cart_ke, rel=2.0 / steps)
    assert r.energy_j == pytest.approx(sum(r.work_j))
    assert r.peak_robot_torque_nm == pytest.approx(0.05)  # the cart's push is not a torque


def test_braking_is_spent_not_recovered():
    model, data = _wheel()
    meter = MotorMeter(model, ["spin"])
    data.qvel[0] = 10.0
    data.ctrl[0] = -0.05  # against the motion until it stops
    for _ in range(500):
        mujoco.mj_step(model, data)
        meter.record(data)
    assert data.qvel[0] < 10.0
    assert meter.report().work_j == (0.0,)


def test_a_screw_through_its_gear_is_a_torque_and_order_follows_the_model():
    model, _ = _wheel()
    meter = MotorMeter(model, ["lead", "spin"])  # given out of order
    assert meter.names == ("spin", "lead") and meter.linear == (False, False)
    with pytest.raises(ValueError, match="no actuator 'wheel'"):
        MotorMeter(model, ["wheel"])


def test_every_kind_names_its_drives_and_the_row_columns_follow():
    assert drive_actuators("fivebar", "parallel_jaw") == (
        ("theta1", "theta2", "z"),
        ("gripper", "wrist"),
    )
    assert drive_actuators("delta", "plug_claws") == (
        ("q1", "q2", "q3"),
        ("rotary", "cylinder_left", "cylinder_right"),
    )
    assert drive_actuators("serial4", "fuzzy_gripper") == (
        ("base", "shoulder", "elbow"),
        ("gripper",),
    )
    assert motor_columns(None) == {"motor_energy_j": None, "peak_motor_torque_nm": None}
    assert motor_columns({"energy_j": 2.5, "peak_robot_torque_nm": 0.4}) == {
        "motor_energy_j": 2.5,
        "peak_motor_torque_nm": 0.4,
    }


def test_the_five_bar_trial_reports_its_drives_and_lifting_costs_work():
    from transplanter.scenario.assemble import assemble
    from transplanter.twin.trial import run_trial

    sc = load_scenario("paper", {"scenario.seedlings": 2})
    d = run_trial(assemble(sc, preflight=True)).to_dict()
    m = d["motors"]
    names = [x["name"] for x in m["drives"]]
    assert names == ["theta1", "theta2", "z", "gripper", "wrist"]
    by = {x["name"]: x for x in m["drives"]}
    assert by["gripper"]["unit"] == "N" and by["z"]["unit"] == "N m"
    # the Z screw lifts the arm twice a cycle: the most work of any drive
    assert by["z"]["work_j"] == max(x["work_j"] for x in m["drives"]) > 0
    # the steppers' torque never exceeds their holding torque (0.45 N m) by more than the
    # detent and damping terms allow
    assert 0.2 < m["peak_robot_torque_nm"] < 0.6
    assert math.isclose(m["energy_j"], sum(x["work_j"] for x in m["drives"]))
    # two picks within a row: the pace start to start, longer than the cycle (the return)
    assert np.isfinite(d["plants_per_hour"]) and d["plants_per_hour"] == pytest.approx(
        3600 / d["pick_pitch_s"]
    )
    assert d["pick_pitch_s"] > d["cycle_time_s"]


def test_the_peak_is_what_a_drive_gives_for_milliseconds_not_a_single_step():
    model, data = _wheel()
    meter = MotorMeter(model, ["spin"])
    for k in range(400):
        data.ctrl[0] = 1.0 if k == 10 else (0.3 if 100 <= k < 300 else 0.0)
        mujoco.mj_step(model, data)
        meter.record(data)
    # a 1 ms spike of 1 N m through the 5 ms lag: 1 - exp(-1/5); a 200 ms push of 0.3: 0.3
    assert meter.report().peak[0] == pytest.approx(0.3, rel=1e-3)
    spike = MotorMeter(model, ["spin"])
    data.ctrl[0] = 1.0
    mujoco.mj_step(model, data)
    spike.record(data)
    assert spike.report().peak[0] == pytest.approx(-math.expm1(-0.2))
