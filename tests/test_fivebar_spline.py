"""The five-bar's `motion.planner = "bspline5"`: its declared joint limits, the quintic
B-spline through its taught via points (transplanter.machine.planner_via), the M720 via
points and the path-synchronised servo in the SGF, the PGF's program, and one short trial."""

import dataclasses
import math

import numpy as np
import pytest

from transplanter.machine.kinematics.fivebar import FiveBarKinematics
from transplanter.machine.pgf import LinePhase, build_program
from transplanter.machine.planner_bspline import MoveRefused
from transplanter.machine.planner_via import JointLimits, plan_via_move
from transplanter.machine.rig import DirectLink, SimulatedEndstops
from transplanter.machine.sgf import SGF
from transplanter.machine.spline_motion import plan_via_transfer, spline_limits
from transplanter.scenario.assemble import machine_config
from transplanter.scenario.schema import ScenarioError, load_scenario

SPLINE = machine_config(load_scenario("paper", {"motion.planner": "bspline5"}))
LINES = machine_config(load_scenario("paper"))
KIN = SPLINE.sgf.kinematics
Z_UP = 0.060
# the paper's first pickup: lifted grip point, retract (approach) point, drop point
POINTS = np.array([[-0.090, 0.215, Z_UP], [-0.090, 0.180, Z_UP], [0.0, 0.140, Z_UP]])


def test_the_five_bar_declares_joint_limits_from_its_drives():
    # 95 % of the 20 kHz step rate: 9600 microsteps per arm revolution, 400 per mm of Z
    speed = KIN.joint_speed_limits
    assert math.degrees(speed[0]) == pytest.approx(712.5)
    assert math.degrees(speed[0]) == pytest.approx(0.95 * 20000 / 9600 * 360)
    assert speed[2] == pytest.approx(0.95 * 20000 / 400 * 1e-3)
    assert math.degrees(KIN.joint_accel_limits[0]) == pytest.approx(25000.0)
    assert KIN.joint_accel_limits[2] == pytest.approx(25.0)
    assert FiveBarKinematics().joint_speed_limits == speed  # the library default is the same
    limits = spline_limits(KIN, SPLINE.sgf.motion)
    assert limits.names == ("arm1", "arm2", "z") and limits.ee_accel_m_s2 == pytest.approx(4.5)
    custom = load_scenario("paper", {"drives.arm_speed_limit_deg_s": 300.0})
    assert math.degrees(FiveBarKinematics.from_scenario(custom).joint_speed_limits[1]) == 300.0
    # the jaws' limit is the [gripper]'s, not the delta's [motion] one
    other = {"motion.planner": "bspline5", "motion.ee_accel_limit_mm_s2": 2000.0}
    assert spline_limits(KIN, machine_config(load_scenario("paper", other)).sgf.motion) == limits
    other["gripper.carry_accel_limit_mm_s2"] = 3000.0
    carried = spline_limits(KIN, machine_config(load_scenario("paper", other)).sgf.motion)
    assert carried.ee_accel_m_s2 == pytest.approx(3.0)


def test_a_speed_limit_above_the_step_rate_is_refused_naming_the_fix():
    fast = {"motion.planner": "bspline5", "drives.arm_speed_limit_deg_s": 800.0}
    with pytest.raises(ScenarioError, match=r"750 deg/s .* drives.arm_speed_limit_deg_s"):
        machine_config(load_scenario("paper", fast))
    machine_config(load_scenario("paper", {"drives.arm_speed_limit_deg_s": 800.0}))  # lines
    with pytest.raises(ValueError, match="3 positive numbers"):
        FiveBarKinematics(joint_accel_limits=(1.0, 0.0, 1.0))


@pytest.fixture(scope="module")
def plan():
    return plan_via_move(KIN, POINTS, spline_limits(KIN, SPLINE.sgf.motion))


def test_the_transfer_passes_the_taught_points_within_every_limit(plan):
    limits = spline_limits(KIN, SPLINE.sgf.motion)
    spline = plan.spline()
    np.testing.assert_allclose(KIN.point(spline(np.append(0.0, np.cumsum(plan.intervals_s)))),
                               POINTS, atol=1e-12)  # fmt: skip
    for nu in (1, 2):  # rest to rest
        np.testing.assert_allclose(spline([0.0, plan.total_s], nu=nu), 0.0, atol=1e-9)
    # Z holds: every taught point is at Z_up
    t = np.linspace(0.0, plan.total_s, 4001)
    np.testing.assert_allclose(spline(t)[:, 2], Z_UP, atol=1e-12)
    # dense sampling never exceeds a limit, and the binding one is met
    speed, accel = np.abs(spline(t, nu=1)), np.abs(spline(t, nu=2))
    assert (speed <= np.asarray(limits.speed) * (1 + 1e-9)).all()
    assert (accel <= np.asarray(limits.accel) * (1 + 1e-9)).all()
    h = 1e-6
    x = KIN.point(spline(np.clip(t[:, None] + [-h, 0.0, h], 0.0, plan.total_s)))
    ee = np.linalg.norm(x[:, 0] - 2 * x[:, 1] + x[:, 2], axis=-1)[1:-1] / h**2
    assert ee.max() <= limits.ee_accel_m_s2 * 1.001
    assert plan.binding == "end-effector acceleration"
    assert ee.max() == pytest.approx(limits.ee_accel_m_s2, rel=0.01)
    assert plan.peaks["ee_accel"].max() == pytest.approx(limits.ee_accel_m_s2, rel=1e-6)
    # the paper's 4.5 m/s^2; the two straight lines it replaces take 1.08 s at S_h 150 mm/s
    assert limits.ee_accel_m_s2 == pytest.approx(4.5)
    np.testing.assert_allclose(plan.intervals_s, [0.1545, 0.3326], atol=2e-3)
    # end-effector bound: the time scales as 1 / sqrt(limit) (0.3477 s at 8.83 m/s^2)
    faster = plan_via_move(KIN, POINTS, dataclasses.replace(limits, ee_accel_m_s2=8.83))
    assert faster.total_s == pytest.approx(plan.total_s * math.sqrt(4.5 / 8.83), rel=1e-3)


def test_the_plan_is_deterministic_and_a_kept_plan_is_the_same(plan):
    again = plan_via_move(KIN, POINTS, spline_limits(KIN, SPLINE.sgf.motion))
    assert again.intervals_s.tobytes() == plan.intervals_s.tobytes()
    steps = KIN.steps_of_point(POINTS[0])
    first = plan_via_transfer(steps, POINTS, KIN, SPLINE.sgf.motion)
    kept = plan_via_transfer(steps, POINTS, KIN, SPLINE.sgf.motion)
    assert kept.spline_plan is first.spline_plan
    assert first.step_times[0].tobytes() == kept.step_times[0].tobytes()
    assert first.duration_s == pytest.approx(plan.total_s, rel=1e-6)


def test_bad_via_paths_are_refused_naming_the_limit():
    limits = spline_limits(KIN, SPLINE.sgf.motion)
    with pytest.raises(MoveRefused, match="less than 1 um apart") as info:
        plan_via_move(KIN, POINTS[[0, 0, 2]], limits)
    assert info.value.limit == "path"
    with pytest.raises(MoveRefused, match="key point Q1") as info:
        plan_via_move(KIN, [POINTS[0], [0.0, 0.40, Z_UP], POINTS[2]], limits)
    assert info.value.limit == "reach"
    # up to Z's top and down again: the spline overshoots Z's window between the points
    high = [[0.0, 0.14, 0.150], [0.0, 0.16, 0.160], [0.09, 0.20, 0.100]]
    with pytest.raises(MoveRefused, match=r"takes z to 160\.3\d+ mm, outside") as info:
        plan_via_move(KIN, high, limits)
    assert info.value.limit == "joint window"
    with pytest.raises(ValueError, match="one limit per joint"):
        JointLimits(speed=(1.0,), accel=(1.0, 1.0), names=("a", "b"))


def _homed(config):
    sgf = SGF(config)
    start = np.array([math.radians(150.0), math.radians(30.0), 0.10])
    link = DirectLink(sgf, SimulatedEndstops(config, start))
    assert link.send("G28")[-1] == "ok"
    assert link.send("G1 X-90 Y215 Z60 S150")[-1] == "ok"
    return sgf, link


def test_the_sgf_runs_m720_via_points_and_the_g0_as_one_spline_with_the_wrist_on_the_way(plan):
    sgf, link = _homed(SPLINE.sgf)
    sgf.drain_servo_commands()
    assert link.send("M720 X-90 Y180 Z60") == ["ok"]
    assert link.send("M280 P1 S135") == ["ok"]
    assert sgf.drain_servo_commands() == []  # it waits for the transfer
    t0 = link.t
    assert link.send("G0 X0 Y140 Z60") == ["ok"]
    assert link.t - t0 == pytest.approx(plan.total_s, abs=1e-3)
    np.testing.assert_allclose(sgf.position_xyz, POINTS[2], atol=1e-12)
    [(t_servo, servo, deg)] = sgf.drain_servo_commands()
    assert (servo, deg) == (1, 135.0)
    assert t_servo - t0 == pytest.approx(plan.intervals_s[0], abs=1e-3)  # at the retract point
    np.testing.assert_array_equal(sgf.logical_steps, KIN.steps_of_point(POINTS[2]))
    # a G1 after a via point is refused and the via dropped; a G0 without one is a spline too
    assert link.send("M720 X-45 Y180")[-1] == "ok"
    reply = link.send("G1 X0 Y150 S100")[-1]
    assert reply.startswith("error:21") and "send that G0 first" in reply
    t0 = link.t
    assert link.send("G0 X45 Y180")[-1] == "ok"
    limits = spline_limits(KIN, SPLINE.sgf.motion)
    two = plan_via_move(KIN, [POINTS[2], [0.045, 0.18, Z_UP]], limits)
    assert link.t - t0 == pytest.approx(two.total_s, abs=1e-3)


def test_m720_is_refused_without_bspline5():
    sgf, link = _homed(LINES.sgf)
    reply = link.send("M720 X-90 Y180 Z60")[-1]
    assert reply.startswith("error:20") and "motion.planner = 'bspline5'" in reply


def test_the_pgf_sends_the_retract_as_a_via_point_only_with_bspline5():
    lines = build_program(LINES.eeprom, LINES.pgf)
    spline = build_program(SPLINE.eeprom, SPLINE.pgf)
    assert SPLINE.pgf.spline_transfer and not LINES.pgf.spline_transfer
    assert len(lines) == len(spline)
    changed = [(a.phase, a.text, b.text) for a, b in zip(lines, spline, strict=True)
               if a.text != b.text]  # fmt: skip
    assert {phase for phase, _, _ in changed} == {LinePhase.RETRACT, LinePhase.TO_DROP}
    _, before, after = changed[0]
    assert "G1 X-90 Y180 Z60 S150" in before and "M720 X-90 Y180 Z60*" in after
    _, before, after = changed[1]
    assert "G1 X0 Y140 Z60 S150" in before and "G0 X0 Y140 Z60*" in after


def test_a_short_trial_with_bspline5_saves_the_lines_time_less_the_splines():
    from transplanter.scenario.assemble import assemble
    from transplanter.twin.trial import run_trial

    results = {}
    for planner in ("lines", "bspline5"):
        scenario = load_scenario(
            "paper", {"motion.planner": planner, "scenario.seedlings": 3, "scenario.seed": 7}
        )
        results[planner] = run_trial(assemble(scenario))
    lines, spline = results["lines"], results["bspline5"]
    assert lines.successes == spline.successes == 3
    # each cycle is shorter by what its two lines took (1.085, 0.829, 0.695 s for pickups
    # 1-3) less its spline (0.487, 0.367, 0.311 s), the handshakes the same
    np.testing.assert_allclose(lines.cycle_times - spline.cycle_times, [0.598, 0.463, 0.384],
                               atol=0.01)  # fmt: skip


def test_the_preflight_refuses_a_taught_transfer_the_spline_cannot_make():
    from transplanter.scenario.preflight import TaughtRefused, check_machine

    first = dataclasses.replace(SPLINE.eeprom.pickups[0], approach_xy_m=(-0.160, 0.100))
    eeprom = dataclasses.replace(SPLINE.eeprom, pickups=(first, *SPLINE.eeprom.pickups[1:]))
    check_machine(dataclasses.replace(LINES, eeprom=eeprom))  # straight lines can
    with pytest.raises(TaughtRefused, match=r"bspline5 transfer .* arm1 to 235\.9\d+ deg") as info:
        check_machine(dataclasses.replace(SPLINE, eeprom=eeprom))
    assert info.value.key == "taught.pickup[0]" and info.value.pickup == 0
    assert "motion.planner = 'lines'" in str(info.value)


def test_a_via_point_where_the_arm_is_merges_and_its_servo_acts_at_the_start():
    sgf, link = _homed(SPLINE.sgf)
    sgf.drain_servo_commands()
    assert link.send("M720 X-90 Y215 Z60") == ["ok"]  # where the arm is
    assert link.send("M280 P1 S120") == ["ok"]
    assert link.send("M720 X0 Y140 Z60") == ["ok"]  # the target itself
    t0 = link.t
    assert link.send("G0 X0 Y140 Z60") == ["ok"]
    two = plan_via_move(KIN, POINTS[[0, 2]], spline_limits(KIN, SPLINE.sgf.motion))
    assert link.t - t0 == pytest.approx(two.total_s, abs=1e-3)
    [(t_servo, servo, deg)] = sgf.drain_servo_commands()
    assert (servo, deg, t_servo) == (1, 120.0, pytest.approx(t0, abs=1e-9))
    # a G0 to where the arm is, through a via point there, is a line of no length
    assert link.send("M720 X0 Y140") == ["ok"]
    assert link.send("G0 X0 Y140 Z60") == ["ok"]
    np.testing.assert_allclose(sgf.position_xyz, POINTS[2], atol=1e-12)
