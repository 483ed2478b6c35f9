"""The serial 4-DOF servo arm of seed 004 through the kinematics seam: IK and FK agree over the
workspace in both elbow branches, the paper's base angles come out, out-of-reach and
past-limit targets are refused with typed reasons, and the scenario and `transplanter ik`
pick the arm by `[robot] kind = "serial4"`."""

from __future__ import annotations

import math

import numpy as np
import pytest

from transplanter import cli
from transplanter.errors import RefusalReason
from transplanter.kinds import kinematics_class
from transplanter.machine.kinematics import UnreachableError
from transplanter.machine.kinematics.serial4 import (
    Serial4Geometry,
    Serial4Kinematics,
    Serial4Limits,
    fk,
    ik,
)
from transplanter.machine.servo import MG996R, SG90
from transplanter.scenario.assemble import machine_config
from transplanter.scenario.schema import ScenarioError, load_scenario

SERIAL4 = {"robot.kind": "serial4"}


def grid():
    """Targets over the arm's reach: base angle -80..80 deg, radius 30-155 mm, height
    -50..140 mm (paper frame: x forward, y up, z sideways), flattened to (N, 3)."""
    t1 = np.radians(np.linspace(-80.0, 80.0, 9))
    r = np.linspace(0.030, 0.155, 26)
    h = np.linspace(-0.050, 0.140, 20)
    T, R, H = np.meshgrid(t1, r, h, indexing="ij")
    return np.stack([R * np.cos(T), H, R * np.sin(T)], axis=-1).reshape(-1, 3)


@pytest.mark.parametrize("elbow", ["up", "down"])
def test_ik_agrees_with_fk_over_the_workspace_in_both_branches(elbow):
    arm = Serial4Kinematics(elbow=elbow)
    pts = grid()
    report = arm.check(pts)
    assert report.ok.sum() > 1500  # most of the grid is workable in either branch
    good = pts[report.ok]
    joints = arm.joints(good)
    np.testing.assert_allclose(arm.point(joints), good, rtol=0, atol=1e-9)
    theta3 = joints[:, 2]
    assert (theta3 <= 0).all() if elbow == "up" else (theta3 >= 0).all()
    # everything within reach solves (windows aside), and the branches mirror each other
    reach = arm.check(pts).diagnostics["distance"] <= 0.160
    other = ik(arm.geometry, pts, "down" if elbow == "up" else "up")
    both = np.isfinite(other).all(axis=1)
    np.testing.assert_array_equal(both, np.isfinite(arm.joints(pts)).all(axis=1))
    assert both[reach & (arm.check(pts).diagnostics["distance"] >= 1e-3)].all()
    np.testing.assert_allclose(fk(arm.geometry, other[both]), pts[both], atol=1e-9)


def test_fk_of_the_park_pose_and_a_stretched_arm():
    g = Serial4Geometry()
    # upper arm vertical, forearm level: the grip centre 80 mm ahead, 80 mm up
    np.testing.assert_allclose(fk(g, [0, math.pi / 2, -math.pi / 2]), [0.08, 0.08, 0], atol=1e-15)
    # stretched along theta1 = 30 deg: 160 mm out, z = r sin(theta1) to the side
    np.testing.assert_allclose(
        fk(g, [math.radians(30), 0, 0]), [0.16 * math.cos(math.radians(30)), 0, 0.08], atol=1e-15
    )


TABLE3_THETA1_DEG = [0, 0, 0, 6.34, 6.34, 5.71, 26.57, 24.44, 22.62, 26.57]
TABLE3_TARGETS_CM = [
    (9, 2, 0), (9, 3, 0), (9, 4, 0), (9, 5, 1), (9, 6, 1),
    (10, 4, 1), (10, 4, 5), (11, 4, 5), (12, 4, 5), (10, 4, 5),
]  # fmt: skip


def test_the_papers_ten_targets_are_reachable_and_give_its_base_angles():
    arm = Serial4Kinematics()
    pts = np.array(TABLE3_TARGETS_CM) * 0.01
    joints = arm.require(pts)
    np.testing.assert_allclose(np.degrees(joints[:, 0]), TABLE3_THETA1_DEG, atol=0.01)
    np.testing.assert_allclose(arm.point(joints), pts, atol=1e-12)


def test_out_of_reach_targets_are_refused_with_the_reach_and_its_bounds():
    arm = Serial4Kinematics()
    with pytest.raises(UnreachableError) as err:
        arm.require([[0.10, 0.04, 0.0], [0.20, 0.04, 0.05]])
    assert err.value.index == 1
    (refusal,) = err.value.refusals
    assert refusal.reason is RefusalReason.OUT_OF_WORKSPACE
    assert refusal.value == pytest.approx(math.hypot(0.2, 0.04, 0.05) * 1e3)
    assert (refusal.low, refusal.high) == (pytest.approx(0.0), pytest.approx(160.0))
    assert "outside workspace: |P-S|=210.0 mm > l1+l2=160.0 mm" in str(err.value)
    assert "target position not reachable: point 1 at (x, y, z) = (200.000, 40.000, 50.000)" in (
        str(err.value)
    )
    # unequal links leave a hole around the shoulder
    short = Serial4Kinematics(geometry=Serial4Geometry(0.08, 0.05))
    (refusal,) = short.check([0.02, 0.0, 0.0]).refusals[0]
    assert refusal.reason is RefusalReason.OUT_OF_WORKSPACE and refusal.low == pytest.approx(30)
    (refusal,) = arm.check([math.nan, 0.0, 0.0]).refusals[0]
    assert refusal.reason is RefusalReason.NOT_FINITE


def test_past_limit_targets_are_refused_naming_the_joint_and_its_window():
    arm = Serial4Kinematics()
    report = arm.check(
        [
            [-0.10, 0.04, 0.01],  # behind the arm: base angle 174 deg
            [0.10, -0.08, 0.0],  # low and near: the shoulder would dip below horizontal
            [0.01, 0.04, 0.005],  # on the base axis
        ]
    )
    assert not report.ok.any()
    (base,) = report.refusals[0]
    assert base.reason is RefusalReason.JOINT_LIMIT and base.subject == "base angle theta1"
    assert base.value == pytest.approx(math.degrees(math.atan2(0.01, -0.10)))
    assert (base.low, base.high) == (-90.0, 90.0)
    (shoulder,) = report.refusals[1]
    assert shoulder.subject == "shoulder angle theta2" and shoulder.value < 0
    assert "shoulder angle theta2 -1.8 deg outside [0, 180] deg" == shoulder.text()
    (axis,) = report.refusals[2]
    assert axis.reason is RefusalReason.SERIAL_SINGULARITY
    assert axis.short() == "base axis 11.2<20"  # the teach pendant's LCD line
    assert axis.text().startswith("distance from the base axis 11.2 mm outside [20, inf] mm")
    # the elbow window: elbow-down joints are past the elbow-up arm's limits
    down = Serial4Kinematics(elbow="down", limits=Serial4Limits(), park_rad=(0, 1.0, -1.0))
    refusals = down.check([0.09, 0.02, 0.0]).refusals[0]
    assert [r.subject for r in refusals] == ["shoulder angle theta2", "elbow angle theta3"]


def test_a_targets_height_outside_the_range_is_refused_before_the_move():
    arm = Serial4Kinematics()
    assert arm.limit_target([0.1, 0.0, 0.0]) is None
    refusal = arm.limit_target([0.1, -0.06, 0.0])
    assert refusal.reason is RefusalReason.AXIS_RANGE and refusal.subject == "Y"
    assert refusal.text() == "Y -60.000 mm outside [-50, 160] mm"


def test_each_axis_is_a_servo_counting_microseconds_of_pulse_width():
    arm = Serial4Kinematics()
    assert [a.name for a in arm.axes] == ["base", "shoulder", "elbow"]
    base, shoulder, elbow = arm.axes
    assert base.drive.steps_per_unit == pytest.approx(4000 / (2 * math.pi))  # 1 us = 0.09 deg
    # rated speed as a count rate: SG90 60 deg in 0.1 s = 6667 us/s; MG996R in 0.17 s
    assert base.drive.max_step_rate_hz == pytest.approx(2000 / 3 / 0.1)
    assert shoulder.drive.max_step_rate_hz == pytest.approx(2000 / 3 / 0.17)
    assert shoulder.drive.holding_torque_nm == pytest.approx(MG996R.stall_torque_nm)
    assert base.drive.holding_torque_nm == pytest.approx(SG90.stall_torque_nm)
    assert elbow.window == pytest.approx((math.radians(-165), math.radians(15)))
    assert "no switch" in base.switch_name
    np.testing.assert_allclose(arm.home_joints, [0, math.pi / 2, -math.pi / 2])
    # the firmware's pulses: each window's lower end at 500 us, 1 us per 0.09 deg
    pulses = arm.pulse_us([0.0, math.pi / 2, -math.pi / 2])
    np.testing.assert_array_equal(pulses, [1500, 1500, 1333])


def test_the_scenario_picks_the_serial_arm_and_its_section():
    assert kinematics_class("serial4") is Serial4Kinematics
    machine = machine_config(load_scenario("paper", SERIAL4))
    arm = machine.kinematics
    assert isinstance(arm, Serial4Kinematics)
    assert arm.geometry == Serial4Geometry(0.080, 0.080)
    assert arm.servos == (SG90, MG996R, MG996R) and arm.gripper_servo == SG90
    homing = machine.sgf.homing
    assert homing.first_cycle is None and homing.rate_hz == tuple(
        a.drive.max_step_rate_hz for a in arm.axes
    )
    # one key of the section given, the rest keep their defaults
    s = load_scenario("paper", {**SERIAL4, "serial4.l1_mm": 100.0, "serial4.elbow": "down"})
    assert (s.serial4.l1_m, s.serial4.l2_m, s.serial4.elbow) == (0.1, 0.08, "down")
    with pytest.raises(ScenarioError, match="park angle of the elbow"):
        machine_config(load_scenario("paper", {**SERIAL4, "serial4.park_elbow_deg": 30.0}))
    with pytest.raises(ScenarioError, match="serial4.base_servo"):
        load_scenario("paper", {**SERIAL4, "serial4.base_servo": "ds3218"})


def test_transplanter_ik_prints_the_three_joint_angles(capsys):
    status = cli.main(["ik", "100", "40", "50", "--set", "robot.kind=serial4"])
    out = capsys.readouterr().out
    assert status == 0
    lines = out.splitlines()
    assert lines[0] == "theta1 = 26.5651 deg"
    assert lines[1].startswith("theta2 = ") and lines[2].startswith("theta3 = -")
    q = np.radians([float(line.split()[2]) for line in lines[:3]])
    np.testing.assert_allclose(fk(Serial4Geometry(), q), [0.1, 0.04, 0.05], atol=1e-6)
    assert lines[3].startswith("servo pulses: base 1795 us")
    status = cli.main(["ik", "200", "40", "50", "--set", "robot.kind=serial4"])
    assert status == 1
    assert "cannot be reached: outside workspace: |P-S|=210.0 mm" in capsys.readouterr().out


def test_the_sgf_plans_the_serial_arm_in_pulse_microseconds_and_refuses_past_reach():
    """The five-bar's firmware (SGF) runs the arm through the seam: G28 goes to the park pose
    (no switch, see homing_from_scenario), every interpolated point is checked, and a move's
    steps are microseconds of each servo's pulse width."""
    from transplanter.machine.planner import PlanError, plan_program

    machine = machine_config(load_scenario("paper", SERIAL4))
    rows = plan_program(machine, "G28\nG90\nG1 X90 Y40 Z0 S50\nG1 X100 Y40 Z50 S50\n")
    arm = machine.kinematics
    start, end = arm.joints([[0.09, 0.04, 0.0], [0.10, 0.04, 0.05]])
    expected = arm.pulse_us(end) - arm.pulse_us(start)
    np.testing.assert_allclose(rows[3].steps, expected, atol=1)  # counts round per joint
    assert rows[3].duration_s > math.dist((90, 40, 0), (100, 40, 50)) / 50.0  # mm at 50 mm/s
    with pytest.raises(PlanError) as info:
        plan_program(machine, "G28\nG90\nG1 X90 Y40 Z0 S50\nG1 X200 Y40 Z50 S50\n")
    assert info.value.line_no == 4
    assert "error:33" in str(info.value) and "l1+l2=160.0 mm" in str(info.value)
