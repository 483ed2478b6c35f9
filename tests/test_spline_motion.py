"""A spline transfer executed by the controller (transplanter.machine.spline_motion, the SGF's
`motion.planner = "bspline5"`): the sampled time law, its pulses, its checks and refusals."""

import math

import numpy as np
import pytest

from transplanter.machine.delta_drives import DeltaController
from transplanter.machine.kinematics.delta import DeltaKinematics
from transplanter.machine.kinematics.fivebar import FiveBarKinematics
from transplanter.machine.kinematics.serial4 import Serial4Kinematics
from transplanter.machine.motion import MotionConfig
from transplanter.machine.planner_bspline import PickPath, key_points, plan_move
from transplanter.machine.rig import DirectLink, SimulatedEndstops
from transplanter.machine.sgf import SGFConfig
from transplanter.machine.spline_motion import PLAN_TOLERANCE_S, plan_spline_move
from transplanter.scenario.assemble import machine_config
from transplanter.scenario.schema import ScenarioError, load_scenario

KIN = DeltaKinematics()
A = np.array([0.2, 0.2, -0.8])  # the paper's example move (docs/planner.md)
B = np.array([0.25, -0.175, -0.8])
SPLINE = MotionConfig(
    resolution_m=5e-4, accel_m_s2=5.0, profile="scurve", compute_time_per_point_s=1e-4,
    planner="bspline5",
)  # fmt: skip


@pytest.fixture(scope="module")
def move():
    return plan_spline_move(KIN.steps_of_point(A), A, B, KIN, SPLINE)


def test_the_move_samples_the_planned_spline_at_the_point_rate(move):
    plan = move.spline_plan
    assert len(plan.nodes) == 7  # the paper's seven key points (no exit points)
    assert move.duration_s == pytest.approx(plan.total_s, abs=0)
    # the paper's example under its limits, planned to the controller's tolerance
    assert move.duration_s < 1.05
    assert move.duration_s == pytest.approx(0.8215, abs=2 * PLAN_TOLERANCE_S + 1e-3)
    t = move.point_times_s
    np.testing.assert_allclose(np.diff(t)[:-1], 1e-4, rtol=1e-9)
    np.testing.assert_allclose(move.joint_positions, plan.spline()(t), atol=1e-12)
    np.testing.assert_allclose(move.points_xyz[[0, -1]], [A, B], atol=0)
    # every sample's point is the FK of its joints and passes the arm's check
    np.testing.assert_allclose(KIN.joints(move.points_xyz[1:-1]), move.joint_positions[1:-1],
                               atol=1e-9)  # fmt: skip
    assert KIN.check(move.points_xyz).ok.all()
    np.testing.assert_array_equal(move.end_steps, KIN.steps_of_point(B))


def test_the_pulses_follow_the_time_law_within_the_joint_limits(move):
    drives = KIN.drives
    t = np.arange(0.0, move.duration_s, 0.005)
    steps = move.steps_at(t)
    q = np.stack([drives[m].to_position(steps[:, m]) for m in range(3)], axis=1)
    spline = move.spline_plan.spline()
    # the pulse count never lags the time law by more than a pulse and a point's worth
    lag = np.abs(q - spline(t)) / np.array([d.unit_per_step for d in drives])
    speed = np.abs(spline(t, nu=1))
    assert (lag <= 1.0 + speed * 1e-4 / drives[0].unit_per_step + 1e-9).all()
    # the pulse train's speed (over 5 ms) stays inside V_max, and its peak is the plan's
    rate = np.abs(np.diff(q, axis=0)) / 0.005
    assert rate.max() < KIN.max_joint_speed_rad_s
    assert rate.max() == pytest.approx(move.spline_plan.peaks["speed"].max(), rel=0.02)


def test_exit_points_make_nine_key_points_straight_above_the_ends():
    points = key_points(A, B, PickPath(exit_m=0.02))
    assert points.shape == (9, 3)
    np.testing.assert_allclose(points[1], A + [0, 0, 0.02])
    np.testing.assert_allclose(points[-2], B + [0, 0, 0.02])
    plan = plan_move(KIN, A, B, path=PickPath(exit_m=0.02), ftol=1e-4)
    assert plan.intervals_s.shape == (8,)
    with pytest.raises(ValueError, match="exit_m"):
        PickPath(exit_m=0.1)


def _homed(config: SGFConfig):
    controller = DeltaController(config)
    q0 = KIN.joints(np.array([0.0, 0.0, -0.8]))
    link = DirectLink(controller.sgf, SimulatedEndstops(config, q0))
    link.t = 0.0
    assert link.send("G28")[-1].startswith("ok")
    return controller, link


def _config(**motion):
    base = dict(resolution_m=5e-4, accel_m_s2=5.0, profile="scurve",
                compute_time_per_point_s=1e-4, planner="bspline5")  # fmt: skip
    return SGFConfig(
        kinematics=KIN,
        motion=MotionConfig(**{**base, **motion}),
        homing=DeltaKinematics.homing_from_scenario(load_scenario("delta_refill")),
    )


def test_the_sgf_runs_a_g0_as_a_spline_and_a_g1_as_a_line():
    controller, link = _homed(_config())
    assert link.send("G1 X200 Y200 Z-800 S300")[-1] == "ok"
    t0, p0 = link.t, link.pulses.copy()
    assert link.send("G0 X250 Y-175 Z-800")[-1] == "ok"
    spline_s = link.t - t0
    expected = plan_move(KIN, A, B, ftol=PLAN_TOLERANCE_S).total_s
    assert spline_s == pytest.approx(expected, abs=2e-3)
    np.testing.assert_array_equal(link.pulses - p0,
                                  KIN.steps_of_point(B) - KIN.steps_of_point(A))  # fmt: skip
    np.testing.assert_allclose(controller.sgf.position_xyz, B, atol=1e-12)
    # a G1 back is the straight line at its speed (the lines planner's move), and a G0 with
    # no horizontal travel moves as a line too
    t0 = link.t
    assert link.send("G1 X200 Y200 Z-800 S300")[-1] == "ok"
    assert link.t - t0 > 1.3  # 375 mm at 300 mm/s
    assert link.send("G0 Z-750")[-1] == "ok"


def test_a_transfer_that_no_timing_can_make_is_refused_naming_the_limit():
    weak = DeltaKinematics.from_scenario(
        load_scenario("delta_refill", {"delta.joint_torque_limit_nm": 2.9})
    )
    config = SGFConfig(kinematics=weak, motion=_config().motion,
                       homing=_config().homing)  # fmt: skip
    controller, link = _homed(config)
    assert link.send("G1 X250 Y-175 Z-800 S300")[-1] == "ok"
    replies = link.send("G0 X200 Y200 Z-800")
    assert replies[-1].startswith("error:33"), replies
    assert "(joint torque)" in replies[-1] and "gravity alone needs" in replies[-1]
    controller2, link2 = _homed(_config())
    assert link2.send("G1 X250 Y-175 Z-800 S300")[-1] == "ok"
    replies = link2.send("G0 X0 Y700 Z-800")
    assert replies[-1].startswith("error:33") and "(reach)" in replies[-1]


def test_bspline5_is_refused_for_an_arm_without_joint_limits():
    with pytest.raises(ValueError, match="declares no max_joint_speed_rad_s"):
        SGFConfig(kinematics=Serial4Kinematics(), motion=MotionConfig(planner="bspline5"))
    # the five-bar declares its limits (tests/test_fivebar_spline.py)
    SGFConfig(kinematics=FiveBarKinematics(), motion=MotionConfig(planner="bspline5"))
    machine_config(load_scenario("paper", {"motion.planner": "bspline5"}))
    with pytest.raises(ScenarioError, match="motion.planner = 'bspline5'"):
        machine_config(
            load_scenario(
                "paper", {"motion.planner": "bspline5", "drives.z_speed_limit_mm_s": 60.0}
            )
        )
    with pytest.raises(ValueError, match="planner"):
        MotionConfig(planner="spline")
    assert math.isclose(MotionConfig().ee_accel_limit_m_s2, 8.83)


def test_a_transfer_planned_before_is_not_planned_again(move, monkeypatch):
    """A job's transfers repeat (each pickup column's, every row): the plan of the same
    points, path, limits and kinematics is kept, the same bits; another end is planned."""
    import transplanter.machine.spline_motion as sm

    calls = []
    real = sm.plan_move
    monkeypatch.setattr(sm, "plan_move", lambda *a, **k: calls.append(1) or real(*a, **k))
    again = plan_spline_move(KIN.steps_of_point(A), A, B, KIN, SPLINE)
    assert calls == []  # kept from the fixture's
    for got, want in zip(again.step_times, move.step_times, strict=True):
        np.testing.assert_array_equal(got, want)
    assert again.duration_s == move.duration_s
    other = plan_spline_move(KIN.steps_of_point(A), A, B + [0.01, 0.0, 0.0], KIN, SPLINE)
    assert calls == [1] and other.duration_s != move.duration_s
