"""The five-bar's lumped inverse dynamics (FiveBarKinematics.inverse_dynamics: the arms' own
inertia, half of each passive link at its elbow and half at C with the jaws and the heaviest
pot), its masses read from the MuJoCo model (scene.robots.fivebar.arm_masses), and the arm
torque limit the bspline5 planner holds (drives.arm_torque_limit_nm, at the motor shaft)."""

import dataclasses
import math

import numpy as np
import pytest

from transplanter.machine.kinematics.fivebar import FiveBarKinematics, FiveBarMasses
from transplanter.machine.planner_bspline import MoveRefused
from transplanter.machine.planner_via import JointLimits, plan_via_move
from transplanter.machine.spline_motion import spline_limits
from transplanter.scenario.assemble import machine_config
from transplanter.scenario.schema import ScenarioError, load_scenario
from transplanter.scene import SceneConfig
from transplanter.scene.build import robot_model
from transplanter.scene.robots.fivebar import arm_masses

SPLINE = machine_config(load_scenario("paper", {"motion.planner": "bspline5"}))
KIN = SPLINE.sgf.kinematics
LIMITS = spline_limits(KIN, SPLINE.sgf.motion)
Z_UP = 0.060
# the paper's first pickup: lifted grip point, retract (approach) point, drop point
POINTS = np.array([[-0.090, 0.215, Z_UP], [-0.090, 0.180, Z_UP], [0.0, 0.140, Z_UP]])


@pytest.fixture(scope="module")
def plan():
    return plan_via_move(KIN, POINTS, LIMITS)


def _along(plan, n: int = 4001):
    spline = plan.spline()
    t = np.linspace(0.0, plan.total_s, n)
    return t, *(spline(t, nu=k)[:, :2] for k in range(3))


def test_the_machine_takes_the_mujoco_models_masses():
    cfg = SceneConfig()
    masses = KIN.masses
    assert masses == arm_masses(robot_model(cfg), 0.080 + 0.003)  # paper: heaviest pot, shoot
    assert masses.rotor_inertia_kgm2 == pytest.approx(cfg.rotor_inertia_kgm2, rel=1e-12)
    assert masses.passive_link_kg == cfg.passive_link_mass_kg
    # a 120 mm capsule of 60 g about its end: m l^2 / 3 and a little for the caps
    assert masses.active_link_kgm2 == pytest.approx(3.025e-4, rel=1e-3)
    # wrist, palm and column (0.12 kg), the jaws (2 x 0.01), the pot and its shoot (0.083)
    assert masses.end_effector_kg == pytest.approx(0.223, abs=1e-12)
    assert KIN.end_effector_kg() == pytest.approx(0.283)
    # the rotor through the 3:1 belt, the active link, half a passive link at the elbow
    np.testing.assert_allclose(
        KIN.arm_inertia_kgm2(), 4.86e-5 + 3.025e-4 + 0.03 * 0.12**2, rtol=1e-3
    )
    assert KIN.arm_torque_limit_nm == 0.225
    assert LIMITS.torque_nm == (0.225, 0.225)
    # a scenario's masses move the model and the machine alike
    heavy = {"motion.planner": "bspline5", "pots.mass_max_g": 120.0}
    assert machine_config(load_scenario("paper", heavy)).sgf.kinematics.masses.end_effector_kg == (
        pytest.approx(0.263)
    )


def test_end_effector_motion_is_the_fk_differentiated():
    rng = np.random.default_rng(3)
    q0 = np.array(KIN.planar_joints(0.02, 0.19))
    qd, qdd = rng.normal(size=(5, 2)) * 3.0, rng.normal(size=(5, 2)) * 40.0
    h = 1e-4
    for v, a in zip(qd, qdd, strict=True):

        def c_at(t, v=v, a=a):
            return np.array(KIN.planar_point(*(q0 + v * t + 0.5 * a * t * t)))

        c, cd, cdd = KIN.end_effector_motion(q0, v, a)
        np.testing.assert_allclose(c, c_at(0.0), atol=1e-15)
        np.testing.assert_allclose(cd, (c_at(h) - c_at(-h)) / (2 * h), atol=5e-7)
        np.testing.assert_allclose(cdd, (c_at(h) - 2 * c_at(0.0) + c_at(-h)) / h**2, atol=1e-5)


def test_at_rest_the_arms_need_no_torque():
    # the arms turn in a horizontal plane: gravity loads Z only
    q = np.array([KIN.planar_joints(x, 0.2) for x in (-0.09, 0.0, 0.09)])
    assert np.abs(KIN.inverse_dynamics(q, 0 * q, 0 * q)).max() == 0.0


def test_the_torques_work_is_the_kinetic_energy(plan):
    t, q, qd, qdd = _along(plan)
    tau = KIN.inverse_dynamics(q, qd, qdd)  # at the motor shaft
    n = KIN.belt_ratios()
    power = np.sum(tau * n * qd, axis=1)  # the motors turn N times as fast as the arms
    work = np.concatenate([[0.0], np.cumsum(0.5 * (power[1:] + power[:-1]) * np.diff(t))])
    _, cd, _ = KIN.end_effector_motion(q, qd, qdd)
    kinetic = 0.5 * np.sum(
        KIN.arm_inertia_kgm2() * qd * qd, axis=1
    ) + 0.5 * KIN.end_effector_kg() * (np.sum(cd * cd, axis=1))
    assert kinetic.max() > 5e-3  # J: a real move
    np.testing.assert_allclose(work, kinetic, atol=2e-8)
    assert abs(work[-1]) < 2e-8  # from rest to rest: no work at all


def test_a_stretched_motion_needs_one_over_s_squared_of_the_torque(plan):
    _, q, qd, qdd = _along(plan, 101)
    s = 1.7
    np.testing.assert_allclose(
        KIN.inverse_dynamics(q, qd / s, qdd / s**2), KIN.inverse_dynamics(q, qd, qdd) / s**2,
        rtol=1e-12, atol=1e-15,
    )  # fmt: skip


def test_the_paper_transfer_is_held_to_the_torque_limit_without_binding(plan):
    assert plan.binding == "end-effector acceleration"
    peak = plan.peaks["torque"].max(axis=0)
    np.testing.assert_allclose(peak, [0.0579, 0.0488], atol=1e-4)  # N m at the motors
    _, q, qd, qdd = _along(plan)
    assert np.abs(KIN.inverse_dynamics(q, qd, qdd)).max() <= 0.225
    free = dataclasses.replace(LIMITS, torque_nm=None)
    same = plan_via_move(KIN, POINTS, free)
    np.testing.assert_array_equal(same.intervals_s, plan.intervals_s)  # the same bits


def test_a_low_torque_limit_binds_and_the_plan_meets_it(plan):
    low = dataclasses.replace(LIMITS, torque_nm=(0.03, 0.03))
    slow = plan_via_move(KIN, POINTS, low)
    assert slow.binding == "joint torque (arm2)"  # arm 2 swings the load towards the drop
    assert slow.total_s > plan.total_s
    assert slow.peaks["torque"].max() == pytest.approx(0.03, rel=1e-6)
    _, q, qd, qdd = _along(slow)
    assert np.abs(KIN.inverse_dynamics(q, qd, qdd)).max() <= 0.03 * (1 + 1e-6)


def test_a_torque_the_model_cannot_give_is_refused_naming_the_limit():
    class Singular(FiveBarKinematics):
        def inverse_dynamics(self, joints, speeds, accels):
            return np.full(np.shape(joints), np.nan)

    singular = Singular(**{f.name: getattr(KIN, f.name) for f in dataclasses.fields(KIN)})
    with pytest.raises(MoveRefused, match=r"arm1 motor's torque .* not finite") as err:
        plan_via_move(singular, POINTS, LIMITS)
    assert err.value.limit == "joint torque"
    # a torque limit without a dynamics model is refused, naming the key
    bare = dataclasses.replace(KIN, masses=None)
    with pytest.raises(ValueError, match=r"drives.arm_torque_limit_nm\) needs its dynamics"):
        spline_limits(bare, SPLINE.sgf.motion)
    with pytest.raises(ValueError, match="positive torque"):
        dataclasses.replace(KIN, arm_torque_limit_nm=0.0)
    with pytest.raises(ValueError, match="torque_nm must be positive"):
        JointLimits(speed=(1.0,), accel=(1.0,), names=("a",), torque_nm=(0.1, 0.1))
    with pytest.raises(ValueError, match="FiveBarMasses.passive_link_kg"):
        FiveBarMasses(1e-6, 1e-4, -0.06, 0.2)


def test_a_torque_limit_above_the_pull_out_torque_is_refused_naming_the_key():
    spline = {"motion.planner": "bspline5"}  # the limit is the spline planner's
    with pytest.raises(ScenarioError, match=r"drives.arm_torque_limit_nm = 0.5 N m .* 0.45 N m"):
        load_scenario("paper", {**spline, "drives.arm_torque_limit_nm": 0.5})
    load_scenario("paper", {**spline, "drives.arm_torque_limit_nm": 0.45})  # the pull-out torque
    load_scenario("paper", {"drives.arm_torque_limit_nm": 0.5})  # lines do not read it
    # above the corner speed the pull-out torque falls: 1200 deg/s is 10 rev/s at the motor
    fast = {**spline, "drives.arm_speed_limit_deg_s": 1200.0, "drives.arm_torque_limit_nm": 0.4}
    with pytest.raises(ScenarioError, match=r"at most 0\.36\b"):
        load_scenario("paper", fast)
    assert math.isclose(0.45 * 8.0 / 10.0, 0.36)
